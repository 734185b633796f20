"""ascc_sim simulator node: one process owns the world, every robot's true pose and its
virtual iRobot Create behind a pseudo-terminal (the real irobot_create_2_1 driver opens
it), and publishes /clock, the lasers and the ground truth. The simulation itself lives
in ascc_sim.sim / ascc_sim.runner; this file wires parameters, topics and links.

With /use_sim_time false (sim.launch use_sim_time:=false) there is no /clock: the node runs
at a real-time factor of 1 and stamps its messages with the wall clock, as a robot's
drivers do, so the nodes under test run on the wall clock too (bench_cpu.py --wall-clock).

Parameters (private): ``ascc_sim.runner.SimulatorParams``, with ``~robot/*``
(``ascc_sim.sim.RobotModel``) and ``~laser/*`` (``ascc_sim.laser.LaserConfig``); see the
package README, section "In your own launch files".
"""
import json
import os
import sys
import time
import warnings

import rospy
import tf2_ros
from geometry_msgs.msg import PoseStamped
from nav_msgs.msg import MapMetaData, OccupancyGrid, Odometry
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import LaserScan
from visualization_msgs.msg import MarkerArray

from ascc_common.params import from_params
from ascc_sim import messages as M
from ascc_sim.msg import SimObjectArray
from ascc_sim.runner import SimRunner, SimulatorParams
from ascc_sim.sim import Simulation, select_robots
from ascc_sim.world import WorldError, load_world
from irobot_create_2_1.models import model as robot_model
from irobot_create_2_1.pty_link import PtyLink
from irobot_create_2_1.virtual_create import VirtualCreate


def link_name(namespace):
    """File name of a robot's serial link in ~link_dir (launch files build the same)."""
    return (namespace.strip("/").replace("/", "_") or "create") + ".pty"


class SimulatorNode:
    def __init__(self):
        p = from_params(SimulatorParams, rospy.get_param, "~")
        if p.world is None:
            raise ValueError("parameter ~world (path of the world YAML) is not set")
        self.sim_time = bool(rospy.get_param("/use_sim_time", False))
        if not self.sim_time and p.real_time_factor != 1.0:
            raise ValueError("~real_time_factor %g: with /use_sim_time false the simulator "
                             "stamps with the wall clock, which needs a real-time factor of 1"
                             % p.real_time_factor)
        self.map_frame = p.map_frame
        self.link_dir = p.link_dir if p.link_dir is not None else "/tmp/ascc_sim_%d" % (
            os.getpid())
        self.stats_file = p.stats_file
        self.wait_drivers_s = p.wait_for_drivers_s
        self.wait_scans = p.wait_for_scan_subscribers
        self.wait_topics = [rospy.resolve_name(t) for t in p.wait_for_publishers.split()]
        self.model = p.robot
        self.laser_cfg = p.laser

        self.world = load_world(p.world, self.model.radius_m)
        self.specs = select_robots(self.world, p.robots.split())
        # each robot's base as its world file says (create_1: the ASCCbot's wheel base
        # from ~robot; create_2: the Create 2's)
        self.creates = {s.name: VirtualCreate(
            wheel_base_m=self.model.wheel_base_m if s.model == "create_1" else None,
            robot=robot_model(s.model)) for s in self.specs}
        self.sim = Simulation(self.world, self.creates, self.model, self.laser_cfg, p.seed)
        os.makedirs(self.link_dir, exist_ok=True)
        self.links = {s.name: PtyLink(self.creates[s.name],
                                      os.path.join(self.link_dir, link_name(s.namespace)))
                      for s in self.specs}
        rospy.on_shutdown(self.shutdown)
        self.runner = SimRunner(self.sim, self.links, p.physics_dt_s, p.real_time_factor,
                                p.max_sim_time_s)

        # /clock is ROS's one global clock topic. Published synchronously: a queued
        # publisher hands every message to a writer thread, ten times the CPU at 100 Hz.
        if self.sim_time:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", SyntaxWarning)  # "no queue_size" warning
                self.clock_pub = rospy.Publisher("/clock", Clock, queue_size=None)
        self.scan_pubs = {s.name: rospy.Publisher(M.topic_prefix(s) + "scan", LaserScan,
                                                  queue_size=5) for s in self.specs}
        gt = "ground_truth/"
        self.pose_pubs = {s.name: rospy.Publisher(gt + s.name + "/pose", PoseStamped,
                                                  queue_size=10) for s in self.specs}
        self.odom_pubs = {s.name: rospy.Publisher(gt + s.name + "/odom", Odometry,
                                                  queue_size=10) for s in self.specs}
        self.start_pubs = {s.name: rospy.Publisher(gt + s.name + "/start_pose", PoseStamped,
                                                   queue_size=1, latch=True)
                           for s in self.specs}
        self.map_pub = rospy.Publisher(gt + "map", OccupancyGrid, queue_size=1, latch=True)
        self.meta_pub = rospy.Publisher(gt + "map_metadata", MapMetaData, queue_size=1,
                                        latch=True)
        self.objects_pub = rospy.Publisher(gt + "objects", SimObjectArray, queue_size=1,
                                           latch=True)
        self.people_pub = rospy.Publisher(gt + "people", SimObjectArray, queue_size=5,
                                          latch=True)
        self.marker_pub = rospy.Publisher(gt + "markers", MarkerArray, queue_size=1,
                                          latch=True)
        self.markers = M.MarkerBuilder(self.world, self.map_frame, self.model.radius_m)
        self.static_tf = tf2_ros.StaticTransformBroadcaster()
        self._publish_static(p.publish_map_to_odom, p.publish_laser_mount)

        if self.sim_time:
            self.runner.every(p.clock_period(), self.on_clock)
        period = self.laser_cfg.scan_period_s  # 10 Hz for the URG-04LX
        for i, spec in enumerate(self.specs):  # spread the robots' scans over the period
            self.runner.every(period, lambda t, s=spec: self.on_scan(t, s),
                              offset_s=period * i / len(self.specs))
        self.runner.every(1.0 / p.ground_truth_rate_hz, self.on_truth)
        self.runner.every(1.0 / p.marker_rate_hz, self.on_markers)
        rospy.loginfo("ascc_sim: world %s, robots %s, links in %s, real_time_factor %g, "
                      "seed %d, %s", self.world.path,
                      ", ".join("%s (ns '%s')" % (s.name, s.namespace) for s in self.specs),
                      self.link_dir, p.real_time_factor, p.seed,
                      "/clock" if self.sim_time else "on the wall clock (no /clock)")

    def stamp(self, t):
        """The stamp of an output at simulated time t: t itself under /clock, else t on
        the wall clock."""
        return t if self.sim_time else self.runner.stamp_s(t)

    def _publish_static(self, map_to_odom, laser_mount):
        # One publisher per frame: tf2 keeps the last static transform of a child, so a
        # robot description's layer_3 -> laser and ours would replace each other.
        m = self.model
        tfs = []
        for s in self.specs:
            odom, base, laser = M.frame_names(s)
            if laser_mount:
                tfs.append(M.static_transform(0.0, base, laser, m.laser_x_m, m.laser_y_m,
                                              m.laser_z_m, m.laser_yaw_rad))
            if map_to_odom:  # the driver's odom starts at the start pose
                tfs.append(M.static_transform(0.0, self.map_frame, odom, s.pose.x, s.pose.y,
                                              0.0, s.pose.yaw))
            self.start_pubs[s.name].publish(M.truth_pose(0.0, self.map_frame, *s.pose))
        self.static_tf.sendTransform(tfs)
        self.map_pub.publish(M.occupancy_grid(self.world.truth_map, 0.0, self.map_frame))
        self.meta_pub.publish(M.map_metadata(self.world.truth_map, 0.0))
        self.objects_pub.publish(M.objects_array(
            0.0, self.map_frame, [M.world_object(o) for o in self.world.objects]))

    # --- periodic outputs (simulated time) ------------------------------------------------
    def on_clock(self, t):
        self.clock_pub.publish(M.clock(t))

    # Outputs nobody subscribes to are not computed (scan noise is keyed by time, so
    # skipping scans does not change the others).
    def on_scan(self, t, spec):
        pub = self.scan_pubs[spec.name]
        if pub.get_num_connections():
            pub.publish(M.laser_scan(self.stamp(t), M.frame_names(spec)[2], self.laser_cfg,
                                     self.sim.scan(spec.name)))

    def on_truth(self, t):
        t = self.stamp(t)
        for r in self.sim.robots:
            if self.pose_pubs[r.name].get_num_connections():
                self.pose_pubs[r.name].publish(M.truth_pose(t, self.map_frame, r.x, r.y,
                                                            r.yaw))
            if self.odom_pubs[r.name].get_num_connections():
                self.odom_pubs[r.name].publish(M.truth_odometry(
                    t, self.map_frame, M.frame_names(r.spec)[1], r.x, r.y, r.yaw, r.v, r.w))
        if self.sim.people and self.people_pub.get_num_connections():
            self.people_pub.publish(M.objects_array(t, self.map_frame, [
                M.person_object(p.spec, st)
                for p, st in zip(self.sim.people, self.sim.people_states)]))

    def on_markers(self, t):
        if not self.marker_pub.get_num_connections():
            return
        self.marker_pub.publish(self.markers.markers(
            self.stamp(t), [(r.name, r.x, r.y, r.yaw) for r in self.sim.robots],
            [(p.spec, st) for p, st in zip(self.sim.people, self.sim.people_states)]))

    # --- main loop --------------------------------------------------------------------------
    def wait_ready(self):
        """Hold the clock at 0 until every driver has opened its link and sent its start
        sequence (and, if asked, every scan has a subscriber), at most
        ~wait_for_drivers_s of wall time: simulated time starts when the robots listen.
        ~wait_for_publishers: also until those topics are published (e.g. a node that
        first loads a model)."""
        deadline = time.monotonic() + self.wait_drivers_s
        published, asked = set(), 0.0
        while not rospy.is_shutdown():
            for link in self.links.values():
                link.pump()
            missing = [n for n, link in self.links.items() if link.bytes_in == 0]
            if self.wait_scans:
                missing += ["a subscriber of %s" % p.resolved_name
                            for p in self.scan_pubs.values() if not p.get_num_connections()]
            if self.wait_topics and time.monotonic() - asked > 0.5:
                asked = time.monotonic()
                published = {t for t, _ in rospy.get_published_topics()}
            missing += ["a publisher of %s" % t for t in self.wait_topics if t not in published]
            if not missing:
                return
            if time.monotonic() > deadline:
                if self.wait_drivers_s > 0:
                    rospy.logwarn("ascc_sim: starting without %s after %.0f s (no driver "
                                  "on the link?)", ", ".join(missing), self.wait_drivers_s)
                return
            if self.sim_time:
                self.on_clock(0.0)
            time.sleep(0.05)

    def spin(self):
        self.wait_ready()
        self.runner.start()
        while not rospy.is_shutdown() and not self.runner.done:
            self.runner.step()
        if self.runner.done:
            rospy.loginfo("ascc_sim: reached ~max_sim_time_s %.1f s: real-time factor %.2f",
                          self.runner.max_sim_time_s,
                          self.runner.achieved_real_time_factor())
            self.write_stats()
            rospy.signal_shutdown("max_sim_time_s reached")

    def write_stats(self):
        if not self.stats_file:
            return
        with open(self.stats_file, "w", encoding="utf-8") as f:
            json.dump(self.runner.stats(), f, indent=1, sort_keys=True)

    def shutdown(self):
        for link in self.links.values():
            link.close()
        try:
            os.rmdir(self.link_dir)
        except OSError:
            pass  # not empty (someone else's files) or already gone: leave it


def main():
    rospy.init_node("simulator")
    try:
        node = SimulatorNode()
    except (WorldError, KeyError, ValueError, OSError) as exc:
        msg = exc.args[0] if isinstance(exc, KeyError) and exc.args else exc
        rospy.logfatal("ascc_sim: %s", msg)
        sys.exit(1)
    node.spin()

