"""Node `semantic_mapper`: the fusion of thesis 5.2.2 on the running robot (5.6).

The person's location: every ``target`` (target_follower/Target) detection of kind
``~target_kind`` with a range, through the robot pose (TF ``~map_frame`` ->
``~base_frame`` at the frame's stamp), `location.human_location`. Each recognized
``activity`` (semantic_mapping/Activity) is fused at the person's median location over its
window (`semantic_map.SemanticMap`): grid G, location type CL on ``map``
(nav_msgs/OccupancyGrid), eq. 5.1-5.3. Out: ``semantic_labels``
(semantic_mapping/SemanticLabelArray, latched), ``semantic_markers``
(visualization_msgs/MarkerArray, latched: a cylinder and the text per published label),
``activity_prior`` (semantic_mapping/ActivityPrior, latched: the room belief fed back to the
recognizer, once a room rule has fired). Service ``~save`` (std_srvs/Trigger) writes map
YAML + PGM, labels YAML and a PNG to ``~output_dir``; so does shutdown when it is set.
Parameters: `semantic_map.SemanticMapperParams`.
"""
import math
import threading

import rospy
import tf2_ros
from geometry_msgs.msg import Point
from nav_msgs.msg import OccupancyGrid
from std_srvs.srv import Trigger, TriggerResponse
from visualization_msgs.msg import Marker, MarkerArray

from ascc_common.grid import map_from_msg
from ascc_common.params import from_params
from ascc_common.pose2d import yaw_of
from ascc_common.throttle import Throttle
from semantic_mapping.location import human_location
from semantic_mapping.models import DEFAULT_MODELS, load_models
from semantic_mapping.msg import Activity, ActivityPrior, SemanticLabel, SemanticLabelArray
from semantic_mapping.ros import run
from semantic_mapping.semantic_map import COLOURS, LocationError, SemanticMap, SemanticMapperParams
from target_follower.msg import Target


class SemanticMapperNode:
    def __init__(self):
        p = from_params(SemanticMapperParams, rospy.get_param, "~")
        self.p = p
        self.models = load_models(p.models_path or DEFAULT_MODELS)
        self.map = SemanticMap(self.models, p)
        self.lock = threading.Lock()
        self.throttle = Throttle(p.warn_period_s)
        self.tf_buffer = tf2_ros.Buffer(cache_time=rospy.Duration(30.0))
        self.tf_listener = tf2_ros.TransformListener(self.tf_buffer)
        self.pub_labels = rospy.Publisher("semantic_labels", SemanticLabelArray,
                                          queue_size=1, latch=True)
        self.pub_markers = rospy.Publisher("semantic_markers", MarkerArray, queue_size=1,
                                           latch=True)
        self.pub_prior = rospy.Publisher("activity_prior", ActivityPrior, queue_size=1,
                                         latch=True)
        rospy.Subscriber("map", OccupancyGrid, self.on_map, queue_size=1)
        rospy.Subscriber("target", Target, self.on_target, queue_size=5)
        rospy.Subscriber("activity", Activity, self.on_activity, queue_size=10)
        rospy.Service("~save", Trigger, self.on_save)
        rospy.on_shutdown(self.on_shutdown)
        rospy.loginfo("semantic mapper: %s, furniture %s, %.2f m grids",
                      p.models_path or DEFAULT_MODELS, ", ".join(self.models.furniture),
                      p.grid_resolution_m)

    def warn(self, key, text, error=False):
        if self.throttle.ready(key, rospy.get_time()):
            (rospy.logerr if error else rospy.logwarn)("semantic mapper: " + text)

    # -- inputs ---------------------------------------------------------------------------
    def on_map(self, msg):
        """A new map: every label's location type (and so its belief) on it."""
        try:
            grid, info = map_from_msg(msg)
            with self.lock:
                before = [(lab.label, lab.location_type) for lab in self.map.labels.values()]
                self.map.set_map(grid, info)
                after = [(lab.label, lab.location_type) for lab in self.map.labels.values()]
        except ValueError as err:
            self.warn("map", "map ignored: %s" % err)
            return
        if after != before:
            self.publish(msg.header.stamp)

    def on_target(self, msg):
        if msg.header.frame_id.lstrip("/") != self.p.base_frame:
            self.warn("target_frame", "Target in frame %r, not %r: ignored"
                      % (msg.header.frame_id, self.p.base_frame))
            return
        age = (rospy.Time.now() - msg.header.stamp).to_sec()
        if age > self.p.target_max_age_s:
            return  # old frame (the simulator's clock restarted, or a backlog)
        det = next((d for d in msg.detections if d.kind == self.p.target_kind
                    and math.isfinite(d.range_m) and math.isfinite(d.bearing_rad)), None)
        if det is None:
            return
        try:
            tr = self.tf_buffer.lookup_transform(self.p.map_frame, self.p.base_frame,
                                                 msg.header.stamp, rospy.Duration(0.1))
        except (tf2_ros.LookupException, tf2_ros.ConnectivityException,
                tf2_ros.ExtrapolationException) as err:
            self.warn("tf", "no robot pose %s -> %s at the target's stamp: %s"
                      % (self.p.map_frame, self.p.base_frame, err))
            return
        except rospy.exceptions.ROSTimeMovedBackwardsException:
            self.warn("clock", "the clock jumped back while waiting for TF (the simulator "
                      "restarted?): the target ignored")
            return
        t = tr.transform.translation
        x, y = human_location(t.x, t.y, yaw_of(tr.transform.rotation),
                              det.range_m + self.p.body_radius_m,
                              det.bearing_rad)
        with self.lock:
            self.map.track(msg.header.stamp.to_sec(), x, y)

    def on_activity(self, msg):
        try:
            with self.lock:
                out = self.map.observe(msg.header.stamp.to_sec(), msg.activity)
        except LocationError as err:
            self.warn("location", "%s not fused: %s" % (msg.activity, err), error=True)
            return
        if out.label is None:
            rospy.logdebug("semantic mapper: %s not fused: %s", msg.activity, out.skipped)
            return
        lab = out.label
        rospy.loginfo("semantic mapper: %s located at (%.2f, %.2f) m, fused at the label at "
                      "(%.2f, %.2f) m, CL %d -> %s (P %.2f, H %.2f bits)", msg.activity,
                      out.x, out.y, lab.x, lab.y, lab.location_type, lab.text,
                      lab.belief.max(), lab.entropy_bits)
        self.publish(msg.header.stamp)

    # -- outputs --------------------------------------------------------------------------
    def publish(self, stamp):
        with self.lock:
            labels = self.map.published_labels()
            rooms = self.map.room_belief()
        arr = SemanticLabelArray()
        arr.header.stamp, arr.header.frame_id = stamp, self.p.map_frame
        arr.furniture = list(self.models.furniture)
        arr.rooms, arr.room_belief = list(self.models.rooms), [float(v) for v in rooms]
        markers = MarkerArray()
        clear = Marker()  # a label can lose its evidence (a new map, more activities)
        clear.header, clear.ns, clear.action = arr.header, "semantic_labels", Marker.DELETEALL
        markers.markers.append(clear)
        size = 0.8 * self.p.grid_resolution_m
        for i, lab in enumerate(labels):
            m = SemanticLabel(grid_x=lab.grid[0], grid_y=lab.grid[1],
                              position=Point(lab.x, lab.y, 0.0), label=lab.label,
                              text=lab.text, belief=float(lab.belief.max()),
                              entropy_bits=lab.entropy_bits, returned=lab.returned,
                              location_type=lab.location_type, updates=lab.updates,
                              beliefs=[float(v) for v in lab.belief])
            arr.labels.append(m)
            b, g, r = COLOURS[self.models.furniture.index(lab.label) % len(COLOURS)]
            for k, kind in enumerate((Marker.CYLINDER, Marker.TEXT_VIEW_FACING)):
                mk = Marker()
                mk.header = arr.header
                mk.ns, mk.id, mk.type, mk.action = "semantic_labels", 2 * i + k, kind, \
                    Marker.ADD
                mk.pose.position = Point(lab.x, lab.y, 0.05 if k == 0
                                         else self.p.marker_height_m)
                mk.pose.orientation.w = 1.0
                mk.scale.x = mk.scale.y = size if k == 0 else 0.0
                mk.scale.z = 0.1 if k == 0 else 0.25
                mk.color.r, mk.color.g, mk.color.b, mk.color.a = r / 255., g / 255., \
                    b / 255., 0.8 if k == 0 else 1.0
                mk.text = lab.text if k == 1 else ""
                markers.markers.append(mk)
        self.pub_labels.publish(arr)
        self.pub_markers.publish(markers)
        self.publish_prior()

    def publish_prior(self):
        """The activity prior, once a room rule of 5.5 has fired (before, P_t(R) is
        uniform and the recognizer keeps its training prior)."""
        with self.lock:
            rooms = self.map.room_belief()
            prior = self.map.activity_prior()
        if abs(rooms.max() - rooms.min()) < 1e-12:
            return
        msg = ActivityPrior()
        msg.header.stamp = rospy.Time.now()
        msg.activities = list(self.models.activities)
        msg.probability = [float(v) for v in prior]
        self.pub_prior.publish(msg)

    def save(self):
        if not self.p.output_dir:
            raise LocationError("~output_dir is not set")
        with self.lock:
            return self.map.save(self.p.output_dir, self.p.output_name)

    def on_save(self, _req):
        try:
            paths = self.save()
        except (OSError, ValueError) as err:
            return TriggerResponse(success=False, message=str(err))
        rospy.loginfo("semantic mapper: saved %s", ", ".join(sorted(paths.values())))
        return TriggerResponse(success=True, message=paths["labels"])

    def on_shutdown(self):
        if not self.p.output_dir:
            return
        try:
            paths = self.save()
            rospy.loginfo("semantic mapper: saved %s on shutdown", paths["labels"])
        except (OSError, ValueError) as err:
            rospy.logerr("semantic mapper: not saved on shutdown: %s", err)


def main():
    run("semantic_mapper", SemanticMapperNode, "semantic mapper")
