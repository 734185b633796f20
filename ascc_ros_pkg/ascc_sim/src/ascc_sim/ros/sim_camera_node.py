"""ascc_sim sim_camera node: the simulated Q24 camera of one robot. It follows the robot's
true pose and twist (``ground_truth/<robot>/odom``) and the people
(``ground_truth/people``), renders the panorama (``ascc_sim.camera_render``), applies the
sensor model (``ascc_sim.camera_effects``) and publishes it as ``<ns>/camera/*`` and,
optionally, as an MJPEG stream on loopback (``ascc_sim.mjpeg_server``). A simulator-side
node: it may read the ground truth, which no algorithm may.

The callbacks only store the newest messages; a timer (simulated time) renders: an
``ascc_common.paced_timer.PacedTimer``, which wakes once per frame, not on every /clock
message as a ``rospy.Timer`` does, and stops when the node's shutdown starts (a
``rospy.Timer`` could still publish then, to topics rospy has closed).
Parameters: ``ascc_sim.camera_render.SimCameraParams`` and ``~logo_textures``
(``{logo name: PNG path}``); see the package README, node "sim_camera".
"""
import math
import os
import sys
import threading

import cv2
import rospkg
import rospy
import tf2_ros
from nav_msgs.msg import Odometry
from sensor_msgs.msg import CameraInfo, CompressedImage, Image

from ascc_common.paced_timer import PacedTimer
from ascc_common.params import ParamError, from_params
from ascc_common.pose2d import yaw_of
from ascc_sim import messages as M
from ascc_sim.camera_effects import CameraEffects
from ascc_sim.camera_render import Body, CameraRenderer, SimCameraParams, load_textures
from ascc_sim.mjpeg_server import MjpegServer
from ascc_sim.msg import SimObjectArray
from ascc_sim.sim import select_robots
from ascc_sim.world import WorldError, load_world


def resolve_path(path):
    """A file path, with ``package://<pkg>/<path>`` resolved through rospkg."""
    prefix = "package://"
    if not path.startswith(prefix):
        return path
    pkg, _, rest = path[len(prefix):].partition("/")
    return os.path.join(rospkg.RosPack().get_path(pkg), rest)


class SimCameraNode:
    def __init__(self):
        p = from_params(SimCameraParams, rospy.get_param, "~")
        if p.world is None:
            raise ValueError("parameter ~world (path of the world YAML) is not set")
        self.p = p
        self.world = load_world(p.world)
        (self.spec,) = select_robots(self.world, [p.robot])
        textures = {}
        for name, path in dict(rospy.get_param("~logo_textures", {})).items():
            try:
                textures.update(load_textures({str(name): resolve_path(str(path))}))
            except (ValueError, rospkg.ResourceNotFound) as exc:
                rospy.logwarn("sim_camera: %s: posters with logo %r get a plain pattern",
                              exc, name)
        cam = p.camera
        self.renderer = CameraRenderer(self.world, cam, textures, p.wall_height_m,
                                       p.max_range_m)
        self.effects = CameraEffects(p.effects, (cam.height_px, cam.width_px, 3), p.seed)
        self.frame_id = M.camera_frame(self.spec)
        self._lock = threading.Lock()
        self._truth = None  # (stamp_s, x, y, yaw, v, w) of the newest true odometry
        self._people = []
        self._frame = 0
        self.server = None

        prefix = M.topic_prefix(self.spec) + "camera/"
        self.pubs = None
        if p.publish_topics:
            self.pubs = (rospy.Publisher(prefix + "image_raw", Image, queue_size=2),
                         rospy.Publisher(prefix + "image_raw/compressed", CompressedImage,
                                         queue_size=2),
                         rospy.Publisher(prefix + "camera_info", CameraInfo, queue_size=2))
        if p.http_port >= 0:
            self.server = MjpegServer("127.0.0.1", p.http_port, p.http_path)
            port = self.server.start()
            rospy.set_param("~http_bound_port", port)
            rospy.loginfo("sim_camera: MJPEG stream at http://127.0.0.1:%d%s", port,
                          p.http_path)
        base = M.frame_names(self.spec)[1]
        self.static_tf = tf2_ros.StaticTransformBroadcaster()
        tf = M.static_transform(0.0, base, self.frame_id, cam.mount_x_m, cam.mount_y_m,
                                cam.mount_z_m, cam.mount_yaw_rad)
        self.static_tf.sendTransform([tf])
        rospy.Subscriber("ground_truth/%s/odom" % self.spec.name, Odometry, self.on_odom,
                         queue_size=1)
        rospy.Subscriber("ground_truth/people", SimObjectArray, self.on_people, queue_size=1)
        self.timer = PacedTimer(1.0 / p.rate_hz, self.on_timer, rospy.get_time,
                                rospy.core.is_shutdown_requested, name="render")
        rospy.on_shutdown(self.shutdown)
        rospy.loginfo("sim_camera: robot %s (ns '%s'), %d x %d %s at %g Hz, frame %s",
                      self.spec.name, self.spec.namespace, cam.width_px, cam.height_px,
                      cam.layout, p.rate_hz, self.frame_id)

    # --- callbacks: store the newest input only ----------------------------------------
    def on_odom(self, msg):
        pose, tw = msg.pose.pose, msg.twist.twist
        truth = (msg.header.stamp.to_sec(), pose.position.x, pose.position.y,
                 yaw_of(pose.orientation), tw.linear.x, tw.angular.z)
        if not all(math.isfinite(v) for v in truth):
            rospy.logwarn_throttle(10.0, "sim_camera: ignoring ground truth odometry with "
                                         "a non-finite pose or twist")
            return
        with self._lock:
            self._truth = truth

    def on_people(self, msg):
        people = [Body(o.pose.position.x, o.pose.position.y, o.radius, o.height,
                       (o.color.r, o.color.g, o.color.b))
                  for o in msg.objects
                  if all(math.isfinite(v) for v in (o.pose.position.x, o.pose.position.y,
                                                     o.radius, o.height))
                  and o.radius > 0 and o.height > 0]
        if len(people) < len(msg.objects):
            rospy.logwarn_throttle(10.0, "sim_camera: ignoring %d people with a non-finite "
                                         "or non-positive pose or size",
                                   len(msg.objects) - len(people))
        with self._lock:
            self._people = people

    # --- the work, on the timer --------------------------------------------------------
    def wanted(self):
        if self.server is not None:
            return True
        return self.pubs is not None and any(pub.get_num_connections() for pub in self.pubs)

    def on_timer(self):
        if not self.wanted():
            return
        now = rospy.get_time()
        with self._lock:
            truth, people = self._truth, list(self._people)
        if truth is None or now - truth[0] > self.p.truth_timeout_s:
            rospy.logwarn_throttle(10.0, "sim_camera: no ground truth odometry on %s "
                                         "newer than %.1f s: no frame"
                                   % ("ground_truth/%s/odom" % self.spec.name,
                                      self.p.truth_timeout_s))
            return
        t0, x, y, yaw, v, w = truth
        dt = max(0.0, now - t0)  # carry the pose forward to the frame time
        yaw_mid = yaw + 0.5 * w * dt
        x, y, yaw = x + v * dt * math.cos(yaw_mid), y + v * dt * math.sin(yaw_mid), yaw + w * dt
        cam = self.p.camera
        img = self.renderer.render(x, y, yaw, people)
        img = self.effects.apply(img, now, cam.blur_length_px(w, self.p.effects.exposure_s),
                                 self._frame)
        self._frame += 1
        ok, buf = cv2.imencode(".jpg", img, [cv2.IMWRITE_JPEG_QUALITY, self.p.jpeg_quality])
        jpeg = buf.tobytes() if ok else None
        if self.server is not None and jpeg is not None:
            self.server.publish(jpeg)
        if self.pubs is None:
            return
        raw, comp, info = self.pubs
        if raw.get_num_connections():
            raw.publish(M.image_bgr8(now, self.frame_id, img))
        if comp.get_num_connections() and jpeg is not None:
            comp.publish(M.compressed_jpeg(now, self.frame_id, jpeg))
        info.publish(M.camera_info(now, self.frame_id, cam))

    def shutdown(self):
        self.timer.shutdown()
        if self.server is not None:
            self.server.stop()


def main():
    rospy.init_node("sim_camera")
    try:
        SimCameraNode()
    except (WorldError, KeyError, ValueError, ParamError, OSError) as exc:
        msg = exc.args[0] if isinstance(exc, KeyError) and exc.args else exc
        rospy.logfatal("sim_camera: %s", msg)
        sys.exit(1)
    rospy.spin()
