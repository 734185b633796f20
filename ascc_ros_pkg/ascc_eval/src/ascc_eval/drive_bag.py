"""A bag of a scripted drive through one of ascc_sim's worlds, as the robot would record it:
ascc_sim's laser model (URG-04LX) scanning the world along a route, the odometry of its
wheel-encoder model (the Create 1's heading in whole degrees, as the virtual Create reports
it), and the truth. No rospy: the messages are serialized by their genpy classes and written
with ``bagfile.BagRecorder``, so ``rosbag play`` and ``rosbag info`` read the bag and
``replay_mapper.RunBag`` replays it.

Topics (the bag_recorder's names for a run of the simulator; frames as in DESIGN.md):
``/scan`` (``laser``), ``/tf`` (``odom`` -> ``base_link`` at every scan), ``/tf_static``
(``base_link`` -> ``laser``, latched), ``/ground_truth/asccbot/pose`` (the true pose in the
world frame ``map``) and ``/ground_truth/map`` (the world's occupancy, latched). The
odometry starts at the true start pose, so the odometry frame at the start, and with it the
frame of a map made from the bag, is the world frame.
"""
from __future__ import annotations

import io
import math
import os
from dataclasses import dataclass
from typing import Dict, List, Optional, Sequence, Tuple

import numpy as np
import yaml

from ascc_common.pose2d import compose
from ascc_eval.bagfile import BagRecorder, rosbags_type

WORLD_FRAME, ODOM_FRAME, BASE_FRAME, LASER_FRAME = "map", "odom", "base_link", "laser"
TF_LEAD_S = 0.005  # each scan is written this long after the odometry at its stamp

# Loops through ascc_sim's worlds (world frame, metres), kept clear of obstacles
# (bench_mapper.py checks them against the ground truth's clearance). The corridor's is the
# thesis's loop (fig. 2.11): east along the south side, round, and 7 m past the start
# (about 242 m).
ROUTES: Dict[str, List[Tuple[float, float]]] = {
    "office": [(2.5, 7.6), (5.5, 7.2), (6.9, 7.2), (6.9, 5.5), (12.45, 5.5), (12.45, 7.1),
               (14.3, 7.0), (12.45, 7.0), (12.45, 5.5), (9.45, 5.5), (9.45, 3.0), (6.5, 2.6),
               (9.45, 3.0), (9.45, 5.5), (4.65, 5.5), (4.65, 3.0), (2.5, 2.6), (4.65, 3.0),
               (4.65, 5.5), (1.9, 5.5), (1.9, 7.3), (2.5, 7.6), (4.0, 7.5)],
    "lab": [(2.0, 1.5), (7.5, 1.5), (8.3, 2.5), (8.3, 5.5), (7.8, 6.3), (5.0, 6.4), (2.0, 6.3),
            (2.0, 5.5), (2.0, 2.5), (2.0, 1.5), (4.5, 1.5)],
    "corridor": [(5.0, 1.9), (98.1, 1.9), (98.1, 23.1), (1.9, 23.1), (1.9, 1.9), (12.0, 1.9)],
    # held out (walls not all at right angles): round the loop's centre line and on
    "annex": [(6.0, 3.0), (40.0, 3.0), (52.0, 15.0), (52.0, 27.0), (4.0, 24.0), (4.0, 3.0),
              (14.0, 3.0)],
}


@dataclass
class DriveBag:
    """What was written: the scans' stamps [s] and the true and odometry poses there."""

    path: str
    stamps: np.ndarray     # (n,) [s]
    truth: np.ndarray      # (n, 3) x, y [m], yaw [rad] in the world frame
    odom: np.ndarray       # (n, 3) the odometry's pose at each stamp
    length_m: float        # the route's true length


def _serialized(msg) -> bytes:
    buf = io.BytesIO()
    msg.serialize(buf)
    return buf.getvalue()


def _write(bag, topic: str, msg, t_s: float, latching: bool = False) -> None:
    bag.write(topic, rosbags_type(msg._type), msg._md5sum, msg._full_text, int(round(t_s * 1e9)),
              _serialized(msg), latching)


def sim_share() -> str:
    """ascc_sim's package directory (its worlds/ and config/)."""
    import rospkg

    return rospkg.RosPack().get_path("ascc_sim")


def write_drive_bag(path: str, world_name: str, route: Sequence[Tuple[float, float]],
                    seed: int, v_mps: float = 0.3, w_radps: float = 0.8,
                    scan_period_s: float = 0.2, start_s: float = 10.0,
                    share: Optional[str] = None) -> DriveBag:
    """Drive ``route`` (waypoints in the world frame [m]; turn in place, then straight at
    ``v_mps``) through ascc_sim's worlds/``world_name``.yaml (``share``: ascc_sim's
    directory, found by rospkg if None) and write what the robot records, one scan every
    ``scan_period_s`` from bag time ``start_s``. ``seed`` draws the laser's noise and the
    wheels' scale and noise (ascc_sim's config/asccbot.yaml)."""
    from tf2_msgs.msg import TFMessage

    from ascc_navigation import synthetic as S
    from ascc_sim import messages as SM
    from ascc_sim.laser import LaserConfig, LaserModel
    from ascc_sim.world import load_world

    share = share or sim_share()
    world = load_world(os.path.join(share, "worlds", world_name + ".yaml"))
    with open(os.path.join(share, "config", "asccbot.yaml")) as f:
        robot = yaml.safe_load(f)
    rng = np.random.default_rng(seed)
    traj = S.waypoint_trajectory(list(route), v=v_mps, w=w_radps, dt=scan_period_s)
    scale = 1.0 + robot["encoder_scale_sigma"] * rng.standard_normal(2)
    odom = S.wheel_odometry(traj, rng, robot["wheel_base_m"],
                            noise_k=robot["encoder_noise_m_per_sqrt_m"], scale=scale,
                            angle_unit_rad=math.radians(1.0))
    cfg = LaserConfig()
    laser = LaserModel(world.grid, cfg, world.dropout)
    mount = (robot["laser_x_m"], robot["laser_y_m"], math.radians(robot["laser_yaw_deg"]))
    stamps = start_s + scan_period_s * np.arange(traj.shape[0])
    bag = BagRecorder(path)
    try:
        _write(bag, "/tf_static", TFMessage([SM.static_transform(
            start_s, BASE_FRAME, LASER_FRAME, mount[0], mount[1], robot["laser_z_m"],
            mount[2])]), start_s, latching=True)
        _write(bag, "/ground_truth/map", SM.occupancy_grid(world.truth_map, start_s,
                                                           WORLD_FRAME), start_s, latching=True)
        for k, t in enumerate(stamps):
            o, g = odom[k], traj[k]
            _write(bag, "/tf", TFMessage([SM.static_transform(
                t, ODOM_FRAME, BASE_FRAME, o[0], o[1], 0.0, o[2])]), t)
            _write(bag, "/ground_truth/asccbot/pose", SM.truth_pose(t, WORLD_FRAME, *g[:3]), t)
            lx, ly, lth = compose(g[:3], mount)
            ranges = laser.scan(lx, ly, lth, world.circles, rng)
            _write(bag, "/scan", SM.laser_scan(t, LASER_FRAME, cfg, ranges), t + TF_LEAD_S)
    finally:
        bag.close()
    length = float(np.sum(np.hypot(np.diff(traj[:, 0]), np.diff(traj[:, 1]))))
    return DriveBag(path, stamps, traj[:, :3].copy(), odom[:, :3].copy(), length)


