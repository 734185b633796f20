"""The gmapping-compatible mapper without ROS: decides when to update the particle filter,
guards against bad input, and computes what slam_gmapping publishes (map, entropy, map->odom).

The ROS node (``ascc_navigation.ros.slam_mapper_node``) only looks up TF, converts messages
and calls ``SlamMapper.handle_scan`` with plain numbers. Parameters keep gmapping's names: the node
reads ``MapperConfig`` with ``ascc_common.params.from_params`` (names, defaults, units and
bounds are in its fields and ``RbpfConfig``'s).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import List, Optional, Sequence, Tuple

import numpy as np

from ascc_common.grid import GridInfo
from ascc_common.params import nested, param
from ascc_common.pose2d import compose, inverse, relative
from ascc_navigation.laser import LaserMount, prepare_scan
from ascc_navigation.posegraph import LoopClosureConfig, LoopResult, PoseGraph, rebuild_counts
from ascc_navigation.rbpf import RbpfConfig, RbpfSlam, UpdateStats
from ascc_navigation.submap_slam import SubmapConfig, SubmapSlam

STILL = 1e-9  # [m], [rad]: odometry this close to the start's has not moved (rounding)


@dataclass
class MapperConfig:
    """When to update (gmapping's wrapper parameters) plus the filter's ``RbpfConfig``; read
    with ``ascc_common.params.from_params`` (gmapping's names)."""

    linear_update: float = param(1.0, "[m] translation that triggers an update",
                                 "linearUpdate", ge=0.0)
    angular_update: float = param(0.5, "[rad] rotation that triggers an update",
                                  "angularUpdate", ge=0.0)
    temporal_update: float = param(-1.0, "[s] update anyway after this; <0: never",
                                   "temporalUpdate")
    max_urange: float = param(80.0, "[m] usable laser range; beams are cropped to it",
                              "maxUrange", gt=0.0)
    max_range: float = param(-1.0, "[m] beams beyond are discarded; <=0: range_max - 1 cm",
                             "maxRange")
    lskip: int = param(0, "match with every (lskip+1)-th beam")
    throttle_scans: int = param(1, "process every n-th scan only", ge=1)
    # odometry moving more than odom_jump_m between two scans is a jump (reset odometry,
    # teleport): not used as motion, unless the scans are so far apart in time that a robot
    # at odom_jump_speed_mps could have driven it (scans dropped for late TF under load)
    odom_jump_m: float = param(1.0, "[m] odometry jump treated as a reset (not gmapping)",
                               gt=0.0)
    odom_jump_speed_mps: float = param(1.0, "[m/s] a longer step is still motion if slower "
                                       "than this (not gmapping)", ge=0.0)
    # Not gmapping: "submap" replaces the particle filter by the particle-free front end
    # of ascc_navigation.submap_slam (its parameters: SubmapConfig; the grid's cell, bounds
    # and occ_thresh stay RbpfConfig's delta, x/ymin/max, occ_thresh)
    frontend: str = param("rbpf", "rbpf (gmapping's particle filter) or submap (scan to "
                          "submap matching, no particles; not gmapping)",
                          choices=("rbpf", "submap"))
    rbpf: RbpfConfig = nested(RbpfConfig)
    submap: SubmapConfig = nested(SubmapConfig)
    loop: LoopClosureConfig = nested(LoopClosureConfig)


@dataclass
class SlamNodeParams:
    """Everything the slam_mapper node reads (private parameters): ``MapperConfig`` plus
    the node's own settings."""

    mapper: MapperConfig = nested(MapperConfig)
    seed: Optional[int] = param(None, "random seed (unset: random)")
    base_frame: str = param("base_link", "robot frame")
    odom_frame: str = param("odom", "odometry frame")
    map_frame: str = param("map", "map frame")
    map_update_interval: float = param(5.0, "[s] map publication at most this often")
    transform_publish_period: float = param(0.05, "[s] map -> odom TF period; <=0: none")
    tf_delay: Optional[float] = param(None, "[s] map -> odom post-dating (unset: "
                                            "transform_publish_period)")
    tf_wait_s: float = param(0.5, "[s] wait for a scan's TF")
    process_period_s: float = param(0.05, "[s] scan timer (ROS time): feeds the queued "
                                          "scans to the filter")

    def tf_delay_s(self) -> float:
        """``tf_delay``, unset: ``transform_publish_period`` (as gmapping)."""
        return self.transform_publish_period if self.tf_delay is None else self.tf_delay


class ScanInput:
    """The fields of a sensor_msgs/LaserScan the mapper needs (stamp in seconds)."""

    __slots__ = ("stamp", "ranges", "angle_min", "angle_increment", "range_min", "range_max")

    def __init__(self, stamp: float, ranges: Sequence[float], angle_min: float,
                 angle_increment: float, range_min: float, range_max: float):
        self.stamp = float(stamp)
        self.ranges = np.asarray(ranges, dtype=float)
        self.angle_min = float(angle_min)
        self.angle_increment = float(angle_increment)
        self.range_min = float(range_min)
        self.range_max = float(range_max)


# Outcome.status values
STARTED = "started"      # first scan: map initialised
UPDATED = "updated"      # filter updated
SKIPPED = "skipped"      # not moved enough / throttled (normal)
REJECTED = "rejected"    # bad input; ``reason`` says why
RESET = "reset"          # time went backwards: everything restarted with this scan


class Outcome:
    """What ``handle_scan`` did. ``reason`` is a human-readable sentence for warnings."""

    __slots__ = ("status", "reason", "stats", "loop")

    def __init__(self, status: str, reason: str = "", stats: Optional[UpdateStats] = None,
                 loop: Optional[LoopResult] = None):
        self.status = status
        self.reason = reason
        self.stats = stats
        self.loop = loop  # the pose graph's loop search at this update, if any

    @property
    def map_changed(self) -> bool:
        return self.status in (STARTED, UPDATED, RESET)

    def __repr__(self) -> str:
        return "Outcome(%s%s)" % (self.status, ", " + self.reason if self.reason else "")


def check_scan(scan: ScanInput) -> str:
    """Empty string if the scan's metadata and ranges are usable, else why not."""
    if scan.ranges.size == 0:
        return "empty scan (no ranges)"
    for name in ("angle_min", "angle_increment", "range_min", "range_max"):
        if not math.isfinite(getattr(scan, name)):
            return "scan field %s is not finite" % name
    if scan.angle_increment == 0.0:
        return "scan angle_increment is 0"
    if not scan.range_max > max(scan.range_min, 0.0):
        return "scan range_max %.3f is not above range_min %.3f" % (scan.range_max,
                                                                   scan.range_min)
    r = scan.ranges
    with np.errstate(invalid="ignore"):
        valid = (np.isfinite(r) & (r >= scan.range_min)) | np.isposinf(r)
    if not valid.any():
        return "no valid range in the scan (%d beams, all NaN/-inf/below range_min)" % r.size
    return ""


class SlamMapper:
    """slam_gmapping's behaviour on plain data. Not thread-safe: call from one thread."""

    def __init__(self, cfg: MapperConfig, seed: Optional[int] = None):
        self.cfg = cfg
        self.seed = seed
        self._reset_state()

    def _reset_state(self) -> None:
        if self.cfg.frontend == "submap":
            r = self.cfg.rbpf
            r.validate()
            self.slam = SubmapSlam(self.cfg.submap, r.delta, r.occ_thresh,
                                   (r.xmin, r.ymin, r.xmax, r.ymax), r.grow_margin)
        else:
            self.slam = RbpfSlam(self.cfg.rbpf, seed=self.seed)
        self.graph = PoseGraph(self.cfg.loop, hit_offset=0.5 * self.cfg.rbpf.delta)
        self.graph.heading_std_rad = max(self.cfg.rbpf.wall_axis_std_rad, 0.0)
        self.keyframe_updates: List[int] = []  # the filter update of each keyframe
        self.graph.trajectory_source = self._keyframe_trajectory
        self.keyframe_odom: Optional[np.ndarray] = None  # odometry at the last keyframe
        self.last_stamp: Optional[float] = None      # newest scan seen [s]
        self.last_odom: Optional[np.ndarray] = None  # odometry at the newest scan seen
        self.update_odom: Optional[np.ndarray] = None  # odometry at the last filter update
        self.update_stamp: Optional[float] = None
        self.travelled = 0.0  # path length [m] since the last update (as gmapping counts)
        self.turned = 0.0     # absolute rotation [rad] since the last update
        self.scan_count = 0

    def reset(self) -> None:
        """Forget map and trajectory (the next scan starts a new map)."""
        self._reset_state()

    @property
    def started(self) -> bool:
        return self.slam.initialized

    def handle_scan(self, scan: ScanInput, odom_pose, mount: LaserMount) -> Outcome:
        """Process one scan taken at odometry pose ``odom_pose`` (base in odom frame, x y
        theta) with the laser mounted at ``mount``."""
        odom_pose = np.asarray(odom_pose, dtype=float)
        reset_reason = ""
        if self.last_stamp is not None and scan.stamp < self.last_stamp:
            reset_reason = ("time went backwards by %.3f s (bag loop or simulator restart): "
                            "map reset" % (self.last_stamp - scan.stamp))
            self.reset()
        problem = check_scan(scan)
        if problem:
            return Outcome(RESET if reset_reason else REJECTED,
                           "; ".join(p for p in (reset_reason, problem) if p))
        self.scan_count += 1
        previous_odom = self.last_odom
        previous_stamp = self.last_stamp
        self.last_stamp = scan.stamp
        self.last_odom = odom_pose
        if not self.slam.initialized:
            prepared = self._prepare(scan, mount)
            if not prepared.usable:
                return Outcome(REJECTED, "no beam of the first scan returned within maxUrange")
            stats = self.slam.start(odom_pose, prepared)
            self._mark_update(scan.stamp, odom_pose)
            self._add_keyframe(odom_pose, prepared, stats)
            return Outcome(RESET if reset_reason else STARTED, reset_reason, stats)
        step = relative(previous_odom, odom_pose)
        jump = math.hypot(step[0], step[1])
        gap = scan.stamp - previous_stamp
        if jump > self.cfg.odom_jump_m and jump > self.cfg.odom_jump_speed_mps * gap:
            # The odometry frame jumped (driver restart, odometry reset); the robot could not
            # have driven that far since the previous scan: re-anchor, as if it had not moved.
            # (A long step after a long gap, e.g. scans dropped for late TF, is motion.)
            self.update_odom = compose(odom_pose, relative(previous_odom, self.update_odom))
            if self.keyframe_odom is not None:
                self.keyframe_odom = compose(odom_pose, relative(previous_odom,
                                                                 self.keyframe_odom))
            return Outcome(REJECTED, "odometry jumped by %.2f m in %.2f s between two scans "
                           "(more than odom_jump_m, faster than odom_jump_speed_mps): motion "
                           "ignored" % (jump, gap))
        self.travelled += jump
        self.turned += abs(float(step[2]))
        if self.scan_count % self.cfg.throttle_scans:
            return Outcome(SKIPPED, "throttled")
        if not self._due(scan.stamp):
            if (self.travelled < STILL and self.turned < STILL
                    and self.slam.wants_still_scans()):
                # the odometry has not changed since the start (but for rounding): the
                # front end may average what it measures there
                self.slam.observe_still(self._prepare(scan, mount))
            return Outcome(SKIPPED, "not moved enough")
        prepared = self._prepare(scan, mount)
        stats = self.slam.update(relative(self.update_odom, odom_pose), prepared)
        self._mark_update(scan.stamp, odom_pose)
        loop = self._add_keyframe(odom_pose, prepared, stats) if prepared.usable else None
        return Outcome(UPDATED, "" if prepared.usable else
                       "no beam returned within maxUrange: odometry only", stats, loop)

    def _add_keyframe(self, odom_pose: np.ndarray, prepared,
                      stats: UpdateStats) -> Optional[LoopResult]:
        """Keyframe for the pose graph (filter's best pose, this scan); on a loop closure
        the map is rebuilt from the corrected keyframes and the filter continues on it."""
        if not self.cfg.loop.enabled:
            return None
        delta = (np.zeros(3) if self.keyframe_odom is None
                 else relative(self.keyframe_odom, odom_pose))
        self.keyframe_odom = odom_pose
        self.keyframe_updates.append(self.slam.updates - 1)
        loop = self.graph.add_keyframe(self.slam.best_pose, prepared, delta,
                                       walls_held=stats.wall_axis_used)
        if loop.status == "closed":
            maps = rebuild_counts(self.slam.new_maps, self.graph.poses, self.graph.scans)
            self.slam.restart(self.graph.poses[-1], maps)
            self.slam.set_trajectory(np.array(self.keyframe_updates), self.graph.poses)
        return loop

    def _keyframe_trajectory(self) -> np.ndarray:
        """The best particle's poses at the keyframes (the trajectory its map was built
        from), for the pose graph."""
        return self.slam.trajectory(np.array(self.keyframe_updates))

    def _prepare(self, scan: ScanInput, mount: LaserMount):
        delta = self.cfg.rbpf.delta
        return prepare_scan(scan.ranges, scan.angle_min, scan.angle_increment, scan.range_min,
                            scan.range_max, mount, self.cfg.max_urange,
                            max_range=self.cfg.max_range if self.cfg.max_range > 0 else None,
                            lskip=self.cfg.lskip, free_pullback=delta, hit_offset=0.5 * delta)

    def _due(self, stamp: float) -> bool:
        cfg = self.cfg
        return (self.travelled >= cfg.linear_update or self.turned >= cfg.angular_update
                or 0 <= cfg.temporal_update <= stamp - self.update_stamp)

    def _mark_update(self, stamp: float, odom_pose: np.ndarray) -> None:
        self.update_odom = odom_pose
        self.update_stamp = stamp
        self.travelled = 0.0
        self.turned = 0.0

    def map_to_odom(self) -> np.ndarray:
        """map->odom (x, y, theta) from the best particle; identity before the first scan."""
        if not self.slam.initialized:
            return np.zeros(3)
        return compose(self.slam.best_pose, inverse(self.update_odom))

    def robot_pose(self) -> np.ndarray:
        """Best estimate of base in map at the last update (x, y, theta)."""
        return self.slam.best_pose

    def occupancy(self) -> Tuple[np.ndarray, GridInfo]:
        """The best particle's -1/0/100 grid and geometry."""
        return self.slam.occupancy()
