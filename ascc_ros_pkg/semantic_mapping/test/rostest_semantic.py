#!/usr/bin/env python3
"""rostest, end to end (thesis 5.6, short): the person in orange lies on the bench and
sits on the right chair; the robot follows, maps, and the semantic map labels the bench
"bench" and the chair "chair", each within 0.5 m of the item, with no stray label; the
saved map (YAML + PGM, labels YAML, PNG) matches the published labels; the room belief
names the bedroom (a bench) and is fed back to the recognizer."""
import os
import time
import unittest

import joblib
import rospy
import rostest
import yaml
from rosgraph_msgs.msg import Clock
from std_srvs.srv import Trigger

from ascc_common.map_io import load_map
from ascc_sim.people import ScriptedPerson
from ascc_sim.world import load_world
from ascc_testing.waits import Latest, wait_for
from semantic_mapping.activity import RecognizerConfig
from semantic_mapping.msg import ActivityPrior, SemanticLabelArray
from semantic_mapping.semantic_map import score_items, world_items
from semantic_mapping.training import train

RADIUS_M = 0.5  # [m] a label within this of its item's footprint (the goal)
STRAY_M = 1.0   # [m] every label lies this close to a visited item


class SemanticEndToEndTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("semantic_test")
        cls.labels = Latest("semantic_labels", SemanticLabelArray)
        cls.prior = Latest("activity_prior", ActivityPrior)
        cls.clock = Latest("/clock", Clock)
        path = rospy.get_param("~model")
        started = time.monotonic()
        rec = train([0, 1, 2, 3, 4, 5], RecognizerConfig(window_s=3.0, features="extended",
                                                          hidden=(32,)))
        joblib.dump(rec, path + ".part")
        os.rename(path + ".part", path)  # the node never sees half a file
        rospy.loginfo("semantic test: recognizer trained in %.1f s", time.monotonic() - started)
        cls.path = path
        cls.world = load_world(rospy.get_param("~world"))
        cls.output_dir = rospy.get_param("~output_dir")

    @classmethod
    def tearDownClass(cls):
        os.unlink(cls.path)

    def test_bench_and_chair_labelled(self):
        person = ScriptedPerson(self.world.people[0])
        end_s = person.end_s
        # the route in sim time (plus a window and the filter to catch up), 4x in wall time
        wait_for(lambda: self.clock.msg is not None
                 and self.clock.msg.clock.to_sec() > end_s + 3.0, 4.0 * end_s + 60.0,
                 "the end of the person's route (%.0f s of sim time)" % end_s)
        arr = self.labels.msg
        self.assertIsNotNone(arr, "no semantic_labels published")
        labels = [{"position_m": [m.position.x, m.position.y], "label": m.label}
                  for m in arr.labels]
        summary = ", ".join("%s (%.2f, %.2f) x%d" % (m.text, m.position.x, m.position.y,
                                                     m.updates) for m in arr.labels)
        rospy.loginfo("semantic test: labels %s", summary)
        start = self.world.robots[0].pose  # the mapper's map starts at the robot's pose
        items = world_items(self.world, arr.furniture, (start.x, start.y, start.yaw))
        visited = [it for it in items if it[0] in ("bench", "chair_right")]
        self.assertEqual(len(visited), 2)
        for s in score_items(visited, labels, RADIUS_M):
            self.assertTrue(s.correct, "%s: nearest label %r at %.2f m from it (labels: %s)"
                            % (s.name, s.found, s.distance_m, summary))
        # no stray label (walking, transitions) away from the visited items
        for lab in labels:
            near = score_items(visited, [lab], STRAY_M)
            self.assertTrue(any(s.found for s in near), "stray label %s at (%.2f, %.2f)"
                            % (lab["label"], *lab["position_m"]))
        # the room belief: a bench -> bedroom, fed back as the activity prior
        rooms = dict(zip(arr.rooms, arr.room_belief))
        self.assertEqual(max(rooms, key=rooms.get), "bedroom", rooms)
        self.assertIsNotNone(self.prior.msg, "no activity_prior published")
        prior = dict(zip(self.prior.msg.activities, self.prior.msg.probability))
        self.assertGreater(prior["lying"], prior["typing"])

        # saved: map YAML + PGM, labels YAML, PNG
        save = rospy.ServiceProxy("semantic_mapper/save", Trigger)
        save.wait_for_service(10.0)
        res = save()
        self.assertTrue(res.success, res.message)
        base = os.path.join(self.output_dir, "semantic_map")
        grid, info = load_map(base + ".yaml")
        self.assertGreater(grid.size, 0)
        self.assertTrue(os.path.getsize(base + ".png") > 0)
        with open(base + "_labels.yaml", encoding="utf-8") as f:
            doc = yaml.safe_load(f)
        saved = sorted((d["label"], tuple(d["position_m"])) for d in doc["labels"])
        published = sorted((m.label, (round(m.position.x, 4), round(m.position.y, 4)))
                           for m in self.labels.msg.labels)
        self.assertEqual(saved, published)


if __name__ == "__main__":
    rostest.rosrun("semantic_mapping", "semantic_end_to_end", SemanticEndToEndTest)
