"""ROS messages from simulator state. Message classes only (genpy), no rospy: these
conversions are tested without a master."""
from __future__ import annotations

import math
from typing import Iterable, List, Optional, Sequence, Tuple

import genpy
import numpy as np
from geometry_msgs.msg import (
    Point,
    Point32,
    Pose,
    PoseStamped,
    Quaternion,
    TransformStamped,
    Vector3,
)
from nav_msgs.msg import MapMetaData, OccupancyGrid, Odometry
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import CameraInfo, CompressedImage, Image, LaserScan
from std_msgs.msg import ColorRGBA, Header
from visualization_msgs.msg import Marker, MarkerArray

from ascc_common.camera_model import PanoramicCamera
from ascc_common.grid import grid_to_msg_data
from ascc_common.pose2d import quaternion_from_yaw
from ascc_sim.msg import SimObject, SimObjectArray

from .grid import GridMap
from .laser import LaserConfig
from .people import PersonState
from .world import PersonSpec, RobotSpec, World, WorldObject


def stamp(t_s: float) -> genpy.Time:
    return genpy.Time.from_sec(max(0.0, t_s))


def pose_msg(x: float, y: float, yaw: float, z: float = 0.0) -> Pose:
    return Pose(Point(x, y, z), Quaternion(*quaternion_from_yaw(yaw)))


def frame_names(robot: RobotSpec) -> Tuple[str, str, str]:
    """(odom, base_link, laser) frame ids of a robot: prefixed by its namespace."""
    p = robot.frame_prefix
    return p + "odom", p + "base_link", p + "laser"


def topic_prefix(robot: RobotSpec) -> str:
    """Relative topic prefix of a robot's sensor topics ('' or 'robotA/')."""
    return robot.frame_prefix


def clock(t_s: float) -> Clock:
    return Clock(clock=stamp(t_s))


def laser_scan(t_s: float, frame_id: str, cfg: LaserConfig, ranges: np.ndarray
               ) -> LaserScan:
    n = len(ranges)
    msg = LaserScan()
    msg.header = Header(stamp=stamp(t_s), frame_id=frame_id)
    msg.angle_min = cfg.angle_min_rad
    msg.angle_max = cfg.angle_min_rad + (n - 1) * cfg.angle_increment_rad
    msg.angle_increment = cfg.angle_increment_rad
    msg.scan_time = cfg.scan_period_s
    # The URG-04LX sweeps 1024 steps per scan period.
    msg.time_increment = cfg.scan_period_s * cfg.angle_increment_rad / (2.0 * math.pi)
    msg.range_min = cfg.range_min_m
    msg.range_max = cfg.range_max_m
    msg.ranges = np.asarray(ranges, dtype=np.float32).tolist()
    return msg


def camera_frame(robot: RobotSpec) -> str:
    """The camera's frame id of a robot: ``<ns>/camera``."""
    return robot.frame_prefix + "camera"


def image_bgr8(t_s: float, frame_id: str, img: np.ndarray) -> Image:
    """A sensor_msgs/Image of a BGR uint8 array (height, width, 3)."""
    msg = Image(header=Header(stamp=stamp(t_s), frame_id=frame_id))
    msg.height, msg.width = int(img.shape[0]), int(img.shape[1])
    msg.encoding = "bgr8"
    msg.is_bigendian = 0
    msg.step = msg.width * 3
    msg.data = np.ascontiguousarray(img, dtype=np.uint8).tobytes()
    return msg


JPEG_FORMAT = "bgr8; jpeg compressed bgr8"  # image_transport's compressed plugin (Noetic)


def compressed_jpeg(t_s: float, frame_id: str, jpeg: bytes) -> CompressedImage:
    """A sensor_msgs/CompressedImage of JPEG bytes of a bgr8 image."""
    return CompressedImage(header=Header(stamp=stamp(t_s), frame_id=frame_id),
                           format=JPEG_FORMAT, data=bytes(jpeg))


def camera_info(t_s: float, frame_id: str, cam: PanoramicCamera) -> CameraInfo:
    """The panorama as a CameraInfo: ``distortion_model`` "equirectangular" (equal angles
    per pixel, no D coefficients), ``K`` = [f, 0, cx; 0, f, cy; 0, 0, 1] with f =
    ``px_per_rad`` and (cx, cy) the pixel of bearing 0 and elevation ``pitch_rad`` in the
    top strip; in the double panorama the bottom strip (rows ``height/2`` on) continues
    the clockwise sweep over the rear half (``ascc_common.camera_model``). P = [K | 0],
    R = identity."""
    f = cam.px_per_rad
    u0, _, _ = cam.ray_to_pixel(0.0, cam.pitch_rad)
    cx, cy = float(u0), cam.strip_height_px / 2.0
    msg = CameraInfo(header=Header(stamp=stamp(t_s), frame_id=frame_id))
    msg.height, msg.width = cam.height_px, cam.width_px
    msg.distortion_model = "equirectangular"
    msg.D = []
    msg.K = [f, 0.0, cx, 0.0, f, cy, 0.0, 0.0, 1.0]
    msg.R = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]
    msg.P = [f, 0.0, cx, 0.0, 0.0, f, cy, 0.0, 0.0, 0.0, 1.0, 0.0]
    return msg


def occupancy_grid(grid: GridMap, t_s: float, frame_id: str) -> OccupancyGrid:
    msg = OccupancyGrid()
    msg.header = Header(stamp=stamp(t_s), frame_id=frame_id)
    msg.info = map_metadata(grid, t_s)
    msg.data = grid_to_msg_data(grid.occupancy)
    return msg


def map_metadata(grid: GridMap, t_s: float) -> MapMetaData:
    info = grid.info
    return MapMetaData(map_load_time=stamp(t_s), resolution=info.resolution,
                       width=info.width, height=info.height,
                       origin=pose_msg(info.origin_x, info.origin_y, info.origin_yaw))


def static_transform(t_s: float, parent: str, child: str, x: float, y: float, z: float,
                     yaw: float) -> TransformStamped:
    tf = TransformStamped()
    tf.header = Header(stamp=stamp(t_s), frame_id=parent)
    tf.child_frame_id = child
    tf.transform.translation = Vector3(x, y, z)
    tf.transform.rotation = Quaternion(*quaternion_from_yaw(yaw))
    return tf


def truth_pose(t_s: float, frame_id: str, x: float, y: float, yaw: float) -> PoseStamped:
    return PoseStamped(header=Header(stamp=stamp(t_s), frame_id=frame_id),
                       pose=pose_msg(x, y, yaw))


def truth_odometry(t_s: float, frame_id: str, child_frame_id: str, x: float, y: float,
                   yaw: float, v: float, w: float) -> Odometry:
    """True pose in ``frame_id`` (map) and true body twist in ``child_frame_id``;
    covariances are zero (this is the truth)."""
    msg = Odometry()
    msg.header = Header(stamp=stamp(t_s), frame_id=frame_id)
    msg.child_frame_id = child_frame_id
    msg.pose.pose = pose_msg(x, y, yaw)
    msg.twist.twist.linear.x = v
    msg.twist.twist.angular.z = w
    return msg


def _color(rgb: Sequence[float], a: float = 1.0) -> ColorRGBA:
    return ColorRGBA(float(rgb[0]), float(rgb[1]), float(rgb[2]), a)


def _polygon(points: np.ndarray) -> List[Point32]:
    return [Point32(float(px), float(py), 0.0) for px, py in points]


def world_object(obj: WorldObject) -> SimObject:
    o = SimObject()
    o.name, o.type, o.kind = obj.name, obj.type, obj.kind
    o.pose = pose_msg(obj.pose.x, obj.pose.y, obj.pose.yaw)
    o.footprint.points = _polygon(obj.footprint)
    o.radius = obj.radius_m
    o.height = obj.height_m
    o.color = _color(obj.color)
    o.solid = obj.solid != "none"
    return o


def person_object(spec: PersonSpec, state: PersonState) -> SimObject:
    o = SimObject()
    o.name, o.type, o.kind = spec.name, "person", "person"
    o.pose = pose_msg(state.x, state.y, state.yaw)
    o.radius = spec.radius_m
    o.height = spec.height_m
    o.color = _color(spec.color)
    o.solid = True
    o.activity = state.activity
    o.speed = state.speed_mps
    return o


def objects_array(t_s: float, frame_id: str, objects: Iterable[SimObject]) -> SimObjectArray:
    return SimObjectArray(header=Header(stamp=stamp(t_s), frame_id=frame_id),
                          objects=list(objects))


class MarkerBuilder:
    """Visualization markers of the world's objects, robots and people (for rviz)."""

    def __init__(self, world: World, frame_id: str, robot_radius_m: float):
        self.world = world
        self.frame_id = frame_id
        self.robot_radius_m = robot_radius_m
        self._static: Optional[List[Marker]] = None

    def _marker(self, ns: str, mid: int, mtype: int, t_s: float) -> Marker:
        m = Marker()
        m.header = Header(stamp=stamp(t_s), frame_id=self.frame_id)
        m.ns, m.id, m.type, m.action = ns, mid, mtype, Marker.ADD
        m.pose.orientation.w = 1.0
        m.frame_locked = True
        return m

    def _label(self, ns: str, mid: int, t_s: float, x: float, y: float, z: float,
               text: str) -> Marker:
        m = self._marker(ns, mid, Marker.TEXT_VIEW_FACING, t_s)
        m.pose.position = Point(x, y, z)
        m.scale.z = 0.2
        m.color = ColorRGBA(0.1, 0.1, 0.1, 1.0)
        m.text = text
        return m

    def static_markers(self, t_s: float) -> List[Marker]:
        if self._static is not None:
            return self._static
        out: List[Marker] = []
        for i, obj in enumerate(self.world.objects):
            if obj.type == "cone":
                m = self._marker("cones", i, Marker.CYLINDER, t_s)
                m.pose = pose_msg(obj.pose.x, obj.pose.y, 0.0, obj.height_m / 2)
                m.scale = Vector3(2 * obj.radius_m, 2 * obj.radius_m, obj.height_m)
            elif obj.type == "landmark":
                m = self._marker("landmarks", i, Marker.SPHERE, t_s)
                m.pose = pose_msg(obj.pose.x, obj.pose.y, 0.0, 0.05)
                m.scale = Vector3(0.1, 0.1, 0.1)
            else:
                m = self._marker(obj.type, i, Marker.LINE_STRIP, t_s)
                m.points = [Point(float(px), float(py), 0.02) for px, py in obj.footprint]
                m.points.append(m.points[0])
                m.scale.x = 0.03
                for j, (cx, cy, r) in enumerate(obj.circles):
                    leg = self._marker("legs", 1000 * i + j, Marker.CYLINDER, t_s)
                    leg.pose = pose_msg(float(cx), float(cy), 0.0, 0.15)
                    leg.scale = Vector3(2 * r, 2 * r, 0.3)
                    leg.color = _color(obj.color)
                    out.append(leg)
            m.color = _color(obj.color)
            out.append(m)
            out.append(self._label("labels", i, t_s, obj.pose.x, obj.pose.y,
                                   max(obj.height_m, 0.1) + 0.15,
                                   obj.kind if obj.type == "furniture" else obj.name))
        self._static = out
        return out

    def markers(self, t_s: float, robots: Sequence[Tuple[str, float, float, float]],
                people: Sequence[Tuple[PersonSpec, PersonState]]) -> MarkerArray:
        """All markers: static objects, robots (name, x, y, yaw) and people."""
        out = list(self.static_markers(t_s))
        r = self.robot_radius_m
        for i, (name, x, y, yaw) in enumerate(robots):
            body = self._marker("robots", 2 * i, Marker.CYLINDER, t_s)
            body.pose = pose_msg(x, y, yaw, 0.05)
            body.scale = Vector3(2 * r, 2 * r, 0.1)
            body.color = ColorRGBA(0.3, 0.3, 0.35, 0.8)
            arrow = self._marker("robots", 2 * i + 1, Marker.ARROW, t_s)
            arrow.pose = pose_msg(x, y, yaw, 0.12)
            arrow.scale = Vector3(r, 0.04, 0.04)
            arrow.color = ColorRGBA(0.9, 0.9, 0.1, 1.0)
            out += [body, arrow, self._label("robot_labels", i, t_s, x, y, 0.45, name)]
        for i, (spec, st) in enumerate(people):
            body = self._marker("people", i, Marker.CYLINDER, t_s)
            body.pose = pose_msg(st.x, st.y, st.yaw, spec.height_m / 2)
            body.scale = Vector3(2 * spec.radius_m, 2 * spec.radius_m, spec.height_m)
            body.color = _color(spec.color, 0.9)
            out += [body, self._label("people_labels", i, t_s, st.x, st.y,
                                      spec.height_m + 0.2, "%s: %s" % (spec.name,
                                                                         st.activity))]
        return MarkerArray(markers=out)
