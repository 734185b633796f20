"""target_detector: cones, orange shirts and the logo in the Q24's panorama (thesis 2.4, 5.3).

Subscribes ``camera/image_raw/compressed`` (sensor_msgs/CompressedImage; ``~use_compressed``
false: ``camera/image_raw``, sensor_msgs/Image bgr8/rgb8/mono8), ``odom`` (its yaw rate
sets the logo detector's blur compensation; its poses bring the scan to the picture's
time), ``scan`` (range) and ``camera_latency`` (std_msgs/Float64 [s], the follower's
estimate: the picture was taken at the frame's stamp less it; ``~camera_latency_s``
until one arrives); TF ``~base_frame`` -> the scan's frame gives the laser's pose. The
scan's points are moved by the robot's motion between the picture's time and the scan's
stamp (odometry) before the beam at the target's bearing is picked
(target_follower.detections). Publishes ``target`` (target_follower/Target:
every plausible detection of the ``~kinds``, best first; an empty list = "no target"; one
message per processed frame, so a stale detection is never repeated) and
``target/debug_image`` (sensor_msgs/Image, the detections drawn; only while subscribed).

The camera callback only stores the newest frame (queue size 1); a worker thread
processes it, and drops it when it is older than ``~max_frame_age_s`` by then. Bad input
(a corrupt JPEG, an unsupported encoding, NaN/inf in the scan, a missing template) gets a
throttled warning naming it; the node goes on. Parameters: ``DetectorNodeParams``,
``~camera/*`` (ascc_common.camera_model.PanoramicCamera), ``~cone/*`` and ``~shirt/*``
(ColorParams over the package's config/<kind>.yaml), ``~logo/*`` (LogoParams).
"""
from __future__ import annotations

import math
import os
import threading
from dataclasses import dataclass

import cv2
import numpy as np
import rospkg
import rospy
import tf2_ros
from nav_msgs.msg import Odometry
from sensor_msgs.msg import CompressedImage, Image, LaserScan
from std_msgs.msg import Float64

from ascc_common.camera_model import PanoramicCamera
from ascc_common.params import from_params, param, tree_getter
from ascc_common.pose2d import yaw_from_quaternion, yaw_of
from target_follower.cli import load_config
from target_follower.color_detector import COLOR_KINDS, KINDS, ColorDetector, ColorParams
from target_follower.detections import SHAPES, Scan, TargetShape, locate, motion_between
from target_follower.following import OdomHistory
from target_follower.logo_detector import LogoDetector, LogoParams, load_template
from target_follower.msg import Detection, Target

SCAN_WARN_PERIOD_S = 60.0  # [s] throttle of the NaN/inf-in-scan warning
WARN_PERIOD_S = 5.0  # throttle period of repeated warnings [s]
COLOURS = {"cone": (0, 255, 0), "shirt": (255, 0, 255), "logo": (255, 255, 0)}


@dataclass
class DetectorNodeParams:
    """target_detector's own parameters (the camera and the detectors' are read apart)."""

    kinds: str = param("cone", "comma-separated kinds to detect: cone, shirt, logo")
    use_compressed: bool = param(True, "subscribe camera/image_raw/compressed (else "
                                       "camera/image_raw)")
    max_frame_age_s: float = param(0.5, "[s] frames older than this when processed are "
                                        "dropped", gt=0.0)
    exposure_s: float = param(0.1, "[s] camera exposure: blur = yaw rate x exposure", ge=0.0)
    odom_timeout_s: float = param(0.5, "[s] an older odom counts as standing still", gt=0.0)
    template: str = param("", "logo template image (empty: the package's "
                              "templates/ascc_logo.png)")
    base_frame: str = param("base_link", "the robot frame of the Target message")
    scan_timeout_s: float = param(0.5, "[s] an older scan is not used for the range", gt=0.0)
    laser_gate_m: float = param(0.5, "[m] laser hits count within this of the size "
                                     "estimate ...", gt=0.0)
    laser_gate_fraction: float = param(0.3, "[1] ... or this fraction of it, if larger",
                                       ge=0.0)
    shirt_height_m: float = param(0.6, "[m] height of the orange shirt region", gt=0.0)
    logo_height_m: float = param(0.4, "[m] height of the logo on its poster", gt=0.0)
    target_radius_m: float = param(0.3, "[m] laser hits within this of the camera ray "
                                        "belong to the target", gt=0.0)
    camera_latency_s: float = param(0.0, "[s] the picture was taken this long before the "
                                         "frame's stamp, until a camera_latency message "
                                         "says otherwise", ge=0.0)
    odom_history_s: float = param(3.0, "[s] odometry kept to bring the scan to the "
                                       "picture's time", gt=0.0)

    def kind_list(self):
        kinds = [k.strip() for k in self.kinds.split(",") if k.strip()]
        bad = [k for k in kinds if k not in KINDS]
        if bad or not kinds:
            raise ValueError("~kinds: %r: each must be one of %s" % (self.kinds, KINDS))
        return kinds


def layered_getter(prefix: str, tree: dict):
    """get(name, default): the ROS parameter ``prefix + name``, else the YAML tree's."""
    yaml_get = tree_getter(tree)

    def get(name, default):
        return rospy.get_param(prefix + name, yaml_get(name, default))
    return get


class TargetDetectorNode:
    def __init__(self):
        self.p = p = from_params(DetectorNodeParams, rospy.get_param, "~")
        self.cam = from_params(PanoramicCamera, rospy.get_param, "~camera/")
        self.kinds = p.kind_list()
        pkg = rospkg.RosPack().get_path("target_follower")
        self.detectors = {}
        for kind in self.kinds:
            if kind in COLOR_KINDS:
                tree = load_config(os.path.join(pkg, "config", "%s.yaml" % kind))
                cp = from_params(ColorParams, layered_getter("~%s/" % kind, tree))
                self.detectors[kind] = ColorDetector(kind, cp, self.cam.strip_height_px,
                                                     wrap=self._full_turn())
        self.logo_params = from_params(LogoParams, rospy.get_param, "~logo/")
        self.template_path = p.template or os.path.join(pkg, "templates", "ascc_logo.png")
        self.shapes = {"cone": TargetShape(True, SHAPES["cone"].height_m, p.target_radius_m),
                       "shirt": TargetShape(False, p.shirt_height_m, p.target_radius_m),
                       "logo": TargetShape(False, p.logo_height_m, p.target_radius_m)}

        self.cond = threading.Condition()
        self.pending = None  # the newest (msg, compressed) not processed yet
        self.odom = None  # (receipt time, yaw rate)
        self.odom_lock = threading.Lock()
        self.odom_history = OdomHistory(p.odom_history_s)
        self.latency_s = p.camera_latency_s
        self.scan = None
        self.tf_buffer = tf2_ros.Buffer(cache_time=rospy.Duration(10.0))
        self.tf_listener = tf2_ros.TransformListener(self.tf_buffer)
        self.target_pub = rospy.Publisher("target", Target, queue_size=5)
        self.debug_pub = rospy.Publisher("target/debug_image", Image, queue_size=1)
        if p.use_compressed:
            rospy.Subscriber("camera/image_raw/compressed", CompressedImage, self.on_image,
                             callback_args=True, queue_size=1, buff_size=2 ** 22)
        else:
            rospy.Subscriber("camera/image_raw", Image, self.on_image, callback_args=False,
                             queue_size=1, buff_size=2 ** 24)
        rospy.Subscriber("odom", Odometry, self.on_odom, queue_size=5)
        rospy.Subscriber("scan", LaserScan, self.on_scan, queue_size=1)
        rospy.Subscriber("camera_latency", Float64, self.on_latency, queue_size=1)
        self.worker = threading.Thread(target=self.run, name="target_detector", daemon=True)
        self.worker.start()
        rospy.loginfo("target_detector: kinds %s, %s", ",".join(self.kinds),
                      "compressed" if p.use_compressed else "raw")

    # -- callbacks: store the newest input -----------------------------------------------
    def on_image(self, msg, compressed):
        with self.cond:
            self.pending = (msg, compressed)
            self.cond.notify()

    def on_odom(self, msg):
        self.odom = (rospy.get_time(), msg.twist.twist.angular.z)
        p = msg.pose.pose
        pose = (p.position.x, p.position.y, yaw_of(p.orientation))
        if all(math.isfinite(v) for v in pose):
            with self.odom_lock:
                self.odom_history.add(msg.header.stamp.to_sec(), pose)

    def on_latency(self, msg):
        if math.isfinite(msg.data) and msg.data >= 0.0:
            self.latency_s = msg.data
        else:
            rospy.logwarn_throttle(WARN_PERIOD_S, "target_detector: camera_latency %r "
                                   "ignored (not a finite value >= 0)" % msg.data)

    def motion(self, stamp, scan_stamp):
        """``Scan.motion``: base_link at the scan's stamp in base_link at the picture's
        time (stamp - latency), from the odometry; none without odometry."""
        with self.odom_lock:
            taken = self.odom_history.pose_at(stamp.to_sec() - self.latency_s)
            scanned = self.odom_history.pose_at(scan_stamp.to_sec())
        if taken is None or scanned is None:
            return (0.0, 0.0, 0.0)
        return motion_between(taken, scanned)

    def on_scan(self, msg):
        self.scan = msg

    # -- the worker ------------------------------------------------------------------------
    def run(self):
        # is_shutdown_requested: true from the start of rospy's shutdown, whose hooks close
        # the publishers while rospy.is_shutdown() is still false
        while not rospy.core.is_shutdown_requested():
            with self.cond:
                while self.pending is None and not rospy.core.is_shutdown_requested():
                    self.cond.wait(0.2)
                item, self.pending = self.pending, None
            if item is None:
                continue
            try:
                self.process(*item)
            except rospy.ROSException:
                if not rospy.core.is_shutdown_requested():
                    raise
                return  # a frame under way when the shutdown started: publishers closed

    def _full_turn(self) -> bool:
        """Does the camera's panorama cover 360 degrees (its ends join)?"""
        return self.cam.strips * self.cam.strip_span_rad >= 2.0 * math.pi - 1e-6

    def _logo_detector(self):
        det = self.detectors.get("logo")
        if det is None:
            try:
                det = LogoDetector(load_template(self.template_path), self.logo_params,
                                   self.cam.strip_height_px, wrap=self._full_turn())
            except ValueError as exc:
                rospy.logwarn_throttle(WARN_PERIOD_S, "target_detector: no logo detection: "
                                       "%s" % exc)
                return None
            self.detectors["logo"] = det
        return det

    def decode(self, msg, compressed):
        """The frame as BGR, or None after a throttled warning."""
        if compressed:
            buf = np.frombuffer(msg.data, np.uint8)
            img = cv2.imdecode(buf, cv2.IMREAD_COLOR) if buf.size else None
            if img is not None and "jpeg" in msg.format.lower() and \
                    not bytes(msg.data).rstrip(b"\0").endswith(b"\xff\xd9"):
                img = None  # truncated: libjpeg pads it with grey and only warns
            if img is None:
                rospy.logwarn_throttle(WARN_PERIOD_S, "target_detector: cannot decode a "
                                       "compressed frame (format %r, %d bytes): corrupt or "
                                       "truncated; skipped" % (msg.format, len(msg.data)))
            return img
        enc = msg.encoding.lower()
        channels = {"bgr8": 3, "rgb8": 3, "mono8": 1}.get(enc)
        if channels is None or msg.height * msg.step != len(msg.data) or \
                msg.step < msg.width * channels:
            rospy.logwarn_throttle(WARN_PERIOD_S, "target_detector: unsupported image "
                                   "(encoding %r, %dx%d, step %d, %d bytes); expected "
                                   "bgr8, rgb8 or mono8; skipped" % (
                                       msg.encoding, msg.width, msg.height, msg.step,
                                       len(msg.data)))
            return None
        a = np.frombuffer(msg.data, np.uint8).reshape(msg.height, msg.step)
        a = a[:, :msg.width * channels].reshape(msg.height, msg.width, channels)
        if enc == "rgb8":
            return cv2.cvtColor(a, cv2.COLOR_RGB2BGR)
        if enc == "mono8":
            return cv2.cvtColor(a, cv2.COLOR_GRAY2BGR)
        return np.ascontiguousarray(a)

    def yaw_rate(self):
        odom = self.odom
        if odom is None or rospy.get_time() - odom[0] > self.p.odom_timeout_s:
            return 0.0
        return odom[1]

    def laser(self, stamp):
        msg = self.scan
        if msg is None or abs((stamp - msg.header.stamp).to_sec()) > self.p.scan_timeout_s:
            return None
        r = np.asarray(msg.ranges, dtype=np.float64)
        bad = int(np.count_nonzero(~np.isfinite(r)))
        if bad:
            # REP 117 allows them (no return, dropout), so once a minute is enough
            rospy.logwarn_throttle(SCAN_WARN_PERIOD_S, "target_detector: scan has %d NaN/inf "
                                   "ranges of %d; those beams are ignored" % (bad, r.size))
        try:
            t = self.tf_buffer.lookup_transform(self.p.base_frame, msg.header.frame_id,
                                                rospy.Time(0), rospy.Duration(0.05))
        except (tf2_ros.LookupException, tf2_ros.ConnectivityException,
                tf2_ros.ExtrapolationException) as exc:
            rospy.logwarn_throttle(WARN_PERIOD_S, "target_detector: no TF %s -> %r (%s); "
                                   "range from size only" % (self.p.base_frame,
                                                            msg.header.frame_id, exc))
            return None
        q = t.transform.rotation
        pose = (t.transform.translation.x, t.transform.translation.y,
                yaw_from_quaternion(q.x, q.y, q.z, q.w))
        return Scan(r, msg.angle_min, msg.angle_increment, msg.range_min, msg.range_max, pose,
                    self.motion(stamp, msg.header.stamp))

    def process(self, msg, compressed):
        stamp = msg.header.stamp
        age = (rospy.Time.now() - stamp).to_sec() if stamp.to_sec() > 0 else 0.0
        if age > self.p.max_frame_age_s:
            rospy.logwarn_throttle(WARN_PERIOD_S, "target_detector: dropping a frame %.2f s "
                                   "old (> ~max_frame_age_s %.2f)" % (age,
                                                                      self.p.max_frame_age_s))
            return
        img = self.decode(msg, compressed)
        if img is None:
            return
        if img.shape[1] != self.cam.width_px or img.shape[0] != self.cam.height_px:
            rospy.logwarn_throttle(WARN_PERIOD_S, "target_detector: frame is %dx%d, the "
                                   "camera model %dx%d (~camera/width_px, height_px); skipped"
                                   % (img.shape[1], img.shape[0], self.cam.width_px,
                                      self.cam.height_px))
            return
        blur = self.cam.blur_length_px(self.yaw_rate(), self.p.exposure_s)
        blobs = []
        for kind in self.kinds:
            if kind == "logo":
                det = self._logo_detector()
                blobs += det.detect(img, blur) if det is not None else []
            else:
                blobs += self.detectors[kind].detect(img)
        blobs.sort(key=lambda b: -b.score)
        scan = self.laser(stamp) if blobs else None
        out = Target()
        out.header.stamp = stamp
        out.header.frame_id = self.p.base_frame
        out.frame_age_s = (rospy.Time.now() - stamp).to_sec() if stamp.to_sec() > 0 else 0.0
        out.detections = [self.detection_msg(locate(self.cam, b, self.shapes[b.kind], scan,
                                                    self.p.laser_gate_m,
                                                    self.p.laser_gate_fraction))
                          for b in blobs]
        self.target_pub.publish(out)
        if self.debug_pub.get_num_connections() > 0:
            self.publish_debug(img, blobs, msg.header)

    @staticmethod
    def detection_msg(loc):
        d = Detection()
        d.kind = loc.kind
        d.bearing_rad = loc.bearing_rad
        d.elevation_rad = loc.elevation_rad
        d.position.x, d.position.y, d.position.z = loc.x_m, loc.y_m, \
            (0.0 if math.isfinite(loc.x_m) else math.nan)
        d.range_m = loc.range_m
        d.range_source = loc.range_source
        d.u_px, d.v_px = loc.blob.u, loc.blob.v
        x, y, w, h = loc.blob.bbox
        d.bbox.x_offset, d.bbox.y_offset = max(0, x), max(0, y)
        d.bbox.width, d.bbox.height = max(0, w), max(0, h)
        d.area_px = loc.blob.area_px
        d.confidence = loc.blob.score
        return d

    def publish_debug(self, img, blobs, header):
        out = img.copy()
        for b in blobs:
            c = COLOURS[b.kind]
            if b.quad is not None:
                cv2.polylines(out, [np.round(b.quad).astype(np.int32)], True, c, 2)
            x, y, w, h = b.bbox
            cv2.rectangle(out, (x, y), (x + w, y + h), c, 1)
            cv2.putText(out, "%s %.2f" % (b.kind, b.score), (x, max(12, y - 4)),
                        cv2.FONT_HERSHEY_SIMPLEX, 0.45, c, 1)
        m = Image()
        m.header = header
        m.height, m.width = out.shape[:2]
        m.encoding = "bgr8"
        m.step = out.shape[1] * 3
        m.data = out.tobytes()
        self.debug_pub.publish(m)


def main():
    rospy.init_node("target_detector")
    TargetDetectorNode()
    rospy.spin()
