"""Node ``q24_camera``: the Mobotix Q24's MJPEG-over-HTTP stream as ROS images (thesis 2.2).

A reader thread reads the stream (``target_follower.mjpeg``) and puts each frame into a
one-frame slot (``camera_driver.NewestFrame``); a publisher thread takes the newest frame,
drops it when older than ``~max_frame_age_s`` or not a sound JPEG, and publishes the JPEG
bytes untouched on ``camera/image_raw/compressed`` (and, with ``~publish_raw``, decoded on
``camera/image_raw``), stamped when the frame's first byte arrived. Frames that arrive
while the publisher is busy replace the waiting one (counted as drops): nothing queues
behind the newest frame. ``camera/frame_age`` tells at a fixed rate how old the newest
published frame is; ``/diagnostics`` gives the frame rate, drops, reconnects and the last
error. When the stream ends, stalls, answers 404 or HTML, the reader reconnects with
exponential back-off. Parameters: ``target_follower.camera_driver.Q24CameraParams``.
"""
import math
import sys
import threading
import time

import diagnostic_updater
import rospy
from diagnostic_msgs.msg import DiagnosticStatus
from sensor_msgs.msg import CompressedImage, Image
from std_msgs.msg import Float64

from ascc_common.paced_timer import PacedTimer
from ascc_common.params import ParamError, from_params
from ascc_common.throttle import Throttle
from target_follower import mjpeg
from target_follower.camera_driver import (
    COMPRESSED_FORMAT,
    Backoff,
    NewestFrame,
    Q24CameraParams,
    RateMeter,
    jpeg_problem,
)

WARN_PERIOD_S = 5.0  # each kind of warning at most this often


class Q24CameraNode:
    def __init__(self):
        self.p = p = from_params(Q24CameraParams, rospy.get_param, "~")
        self.url = mjpeg.redact(p.url)  # as logged: no password
        self.slot = NewestFrame()
        self.backoff = Backoff(p.reconnect_min_s, p.reconnect_max_s)
        self.throttle = Throttle(WARN_PERIOD_S)
        self.rate = RateMeter()
        self.lock = threading.Lock()
        self.stop = threading.Event()
        self.connected = False
        self.reconnects = 0
        self.published = 0
        self.corrupt = 0
        self.stale = 0
        self.last_error = ""
        self.newest_s = None  # time.monotonic() of the newest published frame's first byte

        self.compressed_pub = rospy.Publisher("camera/image_raw/compressed", CompressedImage,
                                              queue_size=1)
        self.raw_pub = (rospy.Publisher("camera/image_raw", Image, queue_size=1)
                        if p.publish_raw else None)
        self.age_pub = rospy.Publisher("camera/frame_age", Float64, queue_size=1)
        self.diag = diagnostic_updater.Updater()
        self.diag.setHardwareID("Mobotix Q24 @ %s" % self.url)
        self.diag.add("stream", self.diag_stream)

        rospy.on_shutdown(self.shutdown)
        self.threads = [threading.Thread(target=self.read_loop, name="q24_reader", daemon=True),
                        threading.Thread(target=self.publish_loop, name="q24_publisher",
                                         daemon=True)]
        for thread in self.threads:
            thread.start()
        # PacedTimers: each wakes once per period, not on every /clock message of a
        # simulator, and stops when the shutdown starts (ascc_common.paced_timer)
        self.timers = [PacedTimer(1.0 / p.age_rate_hz, self.on_age_timer, rospy.get_time,
                                  rospy.core.is_shutdown_requested, name="frame_age"),
                       PacedTimer(1.0, self.diag.update, rospy.get_time,
                                  rospy.core.is_shutdown_requested, name="diagnostics")]
        rospy.loginfo("q24_camera: reading %s (timeout %.1f s, frames older than %.2f s "
                      "dropped, raw images %s)", self.url, p.timeout_s, p.max_frame_age_s,
                      "on" if p.publish_raw else "off")

    def warn(self, kind, text):
        """Warn at most once per WARN_PERIOD_S per kind of problem."""
        with self.lock:
            ready = self.throttle.ready(kind, time.monotonic())
        if ready:
            rospy.logwarn("q24_camera: " + text)

    # --- reading ------------------------------------------------------------------------
    def read_loop(self):
        while not self.stop.is_set():
            problem, kind = self.read_stream()
            with self.lock:
                self.connected = False
                self.last_error = problem
                self.reconnects += 1
            if self.stop.is_set():
                return
            delay = self.backoff.next_delay()
            if self.url not in problem:
                problem = "%s: %s" % (self.url, problem)
            self.warn(kind, "%s; reconnecting in %.1f s" % (problem, delay))
            self.stop.wait(delay)

    def read_stream(self):
        """Read one connection until it fails or ends: (the problem, its kind)."""
        frames = None
        try:
            frames = mjpeg.iter_url(self.p.url, self.p.timeout_s)
            for frame in frames:
                if self.stop.is_set():
                    return "shutting down", "shutdown"
                if not self.connected:
                    with self.lock:
                        self.connected = True
                    self.backoff.reset()
                    rospy.loginfo("q24_camera: streaming from %s", self.url)
                self.slot.put(frame)
            return "the stream ended", "ended"
        except mjpeg.MjpegError as exc:
            return str(exc), type(exc).__name__
        finally:
            if frames is not None:
                frames.close()

    # --- publishing ---------------------------------------------------------------------
    def publish_loop(self):
        while not self.stop.is_set():
            frame = self.slot.take(0.5)
            if frame is None or self.stop.is_set():
                continue
            try:
                self.publish(frame)
            except rospy.ROSException:
                return  # shutting down
            except Exception as exc:  # noqa: BLE001 - the publisher thread must survive
                rospy.logerr_throttle(WARN_PERIOD_S, "q24_camera: frame of %d bytes not "
                                      "published: %s: %s" % (len(frame.data),
                                                             type(exc).__name__, exc))

    def publish(self, frame):
        p = self.p
        age_s = time.monotonic() - frame.monotonic_s
        if age_s > p.max_frame_age_s:
            with self.lock:
                self.stale += 1
            self.warn("stale", "dropped a frame %.2f s old (> ~max_frame_age_s %.2f s) from "
                      "%s" % (age_s, p.max_frame_age_s, self.url))
            return
        problem, image = jpeg_problem(frame.data, decode=p.verify_decode, full=p.publish_raw)
        if problem:
            with self.lock:
                self.corrupt += 1
                count = self.corrupt
            self.warn("corrupt", "corrupt frame from %s dropped: %s (%d corrupt so far)"
                      % (self.url, problem, count))
            return
        # the frame's first byte arrived age_s ago (monotonic), now in ROS time
        age_s = time.monotonic() - frame.monotonic_s
        stamp = rospy.Time.from_sec(max(rospy.get_time() - age_s, 0.0))
        msg = CompressedImage()
        msg.header.stamp = stamp
        msg.header.frame_id = p.frame_id
        msg.format = COMPRESSED_FORMAT
        msg.data = frame.data
        self.compressed_pub.publish(msg)
        if self.raw_pub is not None:
            raw = Image()
            raw.header = msg.header
            raw.height, raw.width = image.shape[:2]
            raw.encoding = "bgr8"
            raw.step = raw.width * 3
            raw.data = image.tobytes()
            self.raw_pub.publish(raw)
        with self.lock:
            self.published += 1
            self.newest_s = frame.monotonic_s
            self.rate.tick()

    def newest_age_s(self):
        with self.lock:
            newest = self.newest_s
        return math.inf if newest is None else time.monotonic() - newest

    def on_age_timer(self):
        self.age_pub.publish(Float64(self.newest_age_s()))

    # --- diagnostics --------------------------------------------------------------------
    def diag_stream(self, stat):
        p = self.p
        age = self.newest_age_s()
        with self.lock:
            rate = self.rate.rate_hz()
            connected, error = self.connected, self.last_error
            counts = (self.slot.received, self.published, self.slot.dropped, self.stale,
                      self.corrupt, self.reconnects)
        if age > p.timeout_s:
            stat.summary(DiagnosticStatus.ERROR, "no frame for %s (%s)"
                         % ("ever" if math.isinf(age) else "%.1f s" % age,
                            "connected" if connected else error or "connecting"))
        elif age > p.max_frame_age_s:
            stat.summary(DiagnosticStatus.WARN, "newest frame %.2f s old" % age)
        else:
            stat.summary(DiagnosticStatus.OK, "streaming at %.1f Hz" % rate)
        stat.add("url", self.url)
        stat.add("connected", str(connected))
        stat.add("frame rate [Hz]", "%.2f" % rate)
        stat.add("newest frame age [s]", "%.3f" % age)
        for key, value in zip(("frames received", "frames published",
                               "dropped behind newest", "dropped stale", "dropped corrupt",
                               "reconnects"), counts):
            stat.add(key, str(value))
        stat.add("last error", error)
        return stat

    def shutdown(self):
        self.stop.set()
        self.slot.close()


def main():
    rospy.init_node("q24_camera")
    try:
        Q24CameraNode()
    except ParamError as exc:
        rospy.logfatal("q24_camera: %s", exc)
        sys.exit(1)
    rospy.spin()
