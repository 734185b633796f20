"""The stepping core: true robot poses, differential-drive kinematics, collisions,
bumpers, wheel-encoder noise, laser scans and scripted people, at a fixed time step.

Each robot is moved by what its (virtual) iRobot Create commands its wheels to do; the
core tells the Create what the wheels really travelled (with encoder noise, 0 when
blocked) and whether the bumpers are pressed, so the Create's own odometry -- and the
driver reading it -- drifts against the ground truth kept here. The Create is injected
(duck-typed: ``wheel_speed_cmd_mps``, ``set_bumpers(left, right)``,
``step(dt_s, wheel_travel_m)``), so this module needs neither ROS nor a serial port.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Dict, List, Optional, Sequence, Tuple

import numpy as np

from ascc_common.params import param
from ascc_common.pose2d import wrap_angle

from .laser import LaserConfig, LaserModel
from .people import PersonState, ScriptedPerson
from .world import RobotSpec, World


@dataclass(frozen=True)
class RobotModel:
    """The ASCCbot: iRobot Create base + Hokuyo on the plexiglass stand (the simulator's
    ``~robot/*``, config/asccbot.yaml); angles may be given in degrees (``*_deg``)."""

    radius_m: float = param(0.165, "[m] round footprint (0.33 m)", gt=0.0)
    wheel_base_m: float = param(0.258, "[m] distance between the wheels", gt=0.0)
    max_wheel_accel_mps2: float = param(2.0, "[m/s^2] wheel speed tracking limit", gt=0.0)
    laser_x_m: float = param(0.05, "[m] laser mount in base_link")
    laser_y_m: float = param(0.0, "[m] laser mount in base_link")
    laser_z_m: float = param(0.30, "[m] laser mount in base_link")
    laser_yaw_rad: float = param(0.0, "[rad] laser mount in base_link", degrees=True)
    bump_margin_m: float = param(0.005, "[m] an obstacle this close to the bumper presses it")
    bump_center_half_angle_rad: float = param(math.radians(15.0), "[rad] contacts within "
                                              "+- this press both switches", degrees=True)
    encoder_scale_sigma: float = param(0.003, "[-] per-wheel systematic scale error, drawn "
                                              "per robot", ge=0.0)
    encoder_noise_m_per_sqrt_m: float = param(0.004, "[m/sqrt(m)] wheel travel noise sigma "
                                                     "= k * sqrt(|d|)", ge=0.0)


class RobotState:
    """True state of one simulated robot."""

    def __init__(self, spec: RobotSpec, index: int, create: Any, rng: np.random.Generator,
                 model: RobotModel):
        self.spec = spec
        self.name = spec.name
        self.index = index  # position in the world file (keys this robot's random draws)
        self.create = create
        # the emulated base's wheel base when it has its own (a Create 2), else the model's
        self.wheel_base_m = getattr(create, "wheel_base_m", None) or model.wheel_base_m
        self.rng = rng
        self.x, self.y, self.yaw = spec.pose.x, spec.pose.y, spec.pose.yaw
        self.v_left = 0.0  # actual wheel speeds [m/s]
        self.v_right = 0.0
        self.v = 0.0  # true body twist of the last step [m/s], [rad/s]
        self.w = 0.0
        self.bump_left = False
        self.bump_right = False
        self.blocked = False  # the last step was cut short by a collision
        self.distance_m = 0.0  # true path length so far
        # Wheel-diameter calibration error of this robot: constant for the whole run.
        self.encoder_scale = (1.0 + rng.normal(0.0, model.encoder_scale_sigma),
                              1.0 + rng.normal(0.0, model.encoder_scale_sigma))

    @property
    def pose(self) -> Tuple[float, float, float]:
        return self.x, self.y, self.yaw


def _wheel_command(create: Any) -> Tuple[float, float]:
    cmd = create.wheel_speed_cmd_mps
    if callable(cmd):
        cmd = cmd()
    return float(cmd[0]), float(cmd[1])


def integrate_arc(x: float, y: float, yaw: float, d_left: float, d_right: float,
                  wheel_base: float) -> Tuple[float, float, float]:
    """Exact pose after the wheels travel d_left, d_right [m] on a circular arc."""
    ds = 0.5 * (d_left + d_right)
    dth = (d_right - d_left) / wheel_base
    half = 0.5 * dth
    chord = ds * (math.sin(half) / half if abs(half) > 1e-9 else 1.0)
    return (x + chord * math.cos(yaw + half), y + chord * math.sin(yaw + half),
            wrap_angle(yaw + dth))


class Simulation:
    """All robots and people of one world, stepped at a fixed dt [s].

    Args:
        world: the loaded world.
        creates: robot name -> virtual Create; only these robots are simulated.
        model, laser: robot and laser parameters.
        seed: every random draw (encoder calibration and noise, laser noise) derives from
            it; same seed + same commands -> same run.
    """

    def __init__(self, world: World, creates: Dict[str, Any],
                 model: Optional[RobotModel] = None, laser: Optional[LaserConfig] = None,
                 seed: int = 0):
        model = model if model is not None else RobotModel()
        self.world = world
        self.model = model
        self.time_s = 0.0
        unknown = sorted(set(creates) - {r.name for r in world.robots})
        if unknown:
            raise KeyError("no robot named %s in world %s" % (", ".join(unknown), world.path))
        self.seed = int(seed)
        self.steps = 0
        seeds = np.random.SeedSequence(self.seed).spawn(len(world.robots))
        self.robots: List[RobotState] = []
        for i, spec in enumerate(world.robots):
            if spec.name in creates:
                self.robots.append(RobotState(spec, i, creates[spec.name],
                                              np.random.default_rng(seeds[i]), model))
        self._by_name = {r.name: r for r in self.robots}
        self.people = [ScriptedPerson(p) for p in world.people]
        self.people_states: List[PersonState] = [p.state(0.0) for p in self.people]
        self.laser = LaserModel(world.grid, laser, world.dropout)
        self._static_circles = world.circles

    def robot(self, name: str) -> RobotState:
        return self._by_name[name]

    # ------------------------------------------------------------------ physics

    def _dynamic_circles(self, exclude: Optional[RobotState]) -> List[Tuple[float, float, float]]:
        """Other robots and the people as (x, y, r): few, so plain Python is fastest."""
        rows = [(r.x, r.y, self.model.radius_m) for r in self.robots if r is not exclude]
        rows += [(s.x, s.y, p.spec.radius_m) for p, s in zip(self.people, self.people_states)]
        return rows

    def _static_clear(self, x: float, y: float, reach: float) -> bool:
        """Fast conservative test: nothing static (cells or circles) within ``reach`` of
        (x, y). One lookup in the clearance of the ground-truth map, where the circles
        are rasterised; the margins cover the cell geometry and the rasterisation."""
        t = self.world.truth_map
        ix, iy = t.info.world_to_cell(x, y)
        if not t.info.contains(ix, iy):
            return False
        return bool(t.clearance_m[iy, ix] - t.info.resolution * (math.sqrt(2.0) + 1.0) > reach)

    def _collides(self, robot: RobotState, x: float, y: float,
                  dynamic: Sequence[Tuple[float, float, float]]) -> bool:
        r = self.model.radius_m
        if not self._static_clear(x, y, r):
            if self.world.grid.disc_contact(x, y, r) is not None:
                return True
            st = self._static_circles
            if len(st) and np.any(np.hypot(st[:, 0] - x, st[:, 1] - y) < st[:, 2] + r):
                return True
        for cx, cy, cr in dynamic:
            d_new = math.hypot(cx - x, cy - y)
            # Moving people may walk into a robot; only moves that push deeper are refused.
            if d_new < cr + r and d_new < math.hypot(cx - robot.x, cy - robot.y) - 1e-12:
                return True
        return False

    def _contact_bearing(self, robot: RobotState,
                         dynamic: Sequence[Tuple[float, float, float]]) -> Optional[float]:
        """Bearing [rad, robot frame] of the nearest obstacle within the bump margin."""
        reach = self.model.radius_m + self.model.bump_margin_m
        best: Optional[Tuple[float, float, float]] = None
        circles = list(dynamic)
        if not self._static_clear(robot.x, robot.y, reach):
            best = self.world.grid.disc_contact(robot.x, robot.y, reach)
            circles += [tuple(c) for c in self._static_circles]
        for cx, cy, cr in circles:
            dx, dy = cx - robot.x, cy - robot.y
            dist = math.hypot(dx, dy)
            gap = dist - cr
            if gap < reach and (best is None or gap < best[2]):
                norm = max(dist, 1e-9)
                best = (robot.x + dx / norm * gap, robot.y + dy / norm * gap, gap)
        if best is None:
            return None
        b = math.atan2(best[1] - robot.y, best[0] - robot.x) - robot.yaw
        return wrap_angle(b)

    def _move(self, robot: RobotState, dt: float) -> Tuple[float, float]:
        """Advance one robot; returns what its wheels really travelled (left, right) [m]."""
        m = self.model
        cmd_l, cmd_r = _wheel_command(robot.create)
        dv = m.max_wheel_accel_mps2 * dt
        robot.v_left += min(max(cmd_l - robot.v_left, -dv), dv)
        robot.v_right += min(max(cmd_r - robot.v_right, -dv), dv)
        dl, dr = robot.v_left * dt, robot.v_right * dt
        dynamic = self._dynamic_circles(robot)
        robot.blocked = False
        frac = 1.0
        if dl != 0.0 or dr != 0.0:
            nx, ny, _ = integrate_arc(robot.x, robot.y, robot.yaw, dl, dr, robot.wheel_base_m)
            if (nx, ny) != (robot.x, robot.y) and self._collides(robot, nx, ny, dynamic):
                robot.blocked = True
                lo, hi = 0.0, 1.0  # bisect the largest free fraction of the step
                for _ in range(10):
                    mid = 0.5 * (lo + hi)
                    mx, my, _ = integrate_arc(robot.x, robot.y, robot.yaw, dl * mid, dr * mid,
                                              robot.wheel_base_m)
                    if self._collides(robot, mx, my, dynamic):
                        hi = mid
                    else:
                        lo = mid
                frac = lo
        dl, dr = dl * frac, dr * frac
        x, y, yaw = integrate_arc(robot.x, robot.y, robot.yaw, dl, dr, robot.wheel_base_m)
        robot.v = 0.5 * (dl + dr) / dt
        robot.w = (dr - dl) / robot.wheel_base_m / dt
        robot.distance_m += abs(0.5 * (dl + dr))
        robot.x, robot.y, robot.yaw = x, y, yaw
        bearing = self._contact_bearing(robot, dynamic)
        front = bearing is not None and abs(bearing) <= math.pi / 2
        robot.bump_left = front and bearing >= -m.bump_center_half_angle_rad
        robot.bump_right = front and bearing <= m.bump_center_half_angle_rad
        return dl, dr

    def _encoders(self, robot: RobotState, dl: float, dr: float) -> Tuple[float, float]:
        k = self.model.encoder_noise_m_per_sqrt_m
        nl, nr = robot.rng.normal(0.0, 1.0, 2)
        return (dl * robot.encoder_scale[0] + k * math.sqrt(abs(dl)) * nl,
                dr * robot.encoder_scale[1] + k * math.sqrt(abs(dr)) * nr)

    def step(self, dt_s: float) -> None:
        """Advance the world by dt_s [s]: people, then every robot and its Create."""
        if not dt_s > 0:
            raise ValueError("dt_s must be > 0")
        self.time_s += dt_s
        self.steps += 1
        self.people_states = [p.state(self.time_s) for p in self.people]
        for robot in self.robots:
            dl, dr = self._move(robot, dt_s)
            meas = self._encoders(robot, dl, dr)
            robot.create.set_bumpers(robot.bump_left, robot.bump_right)
            robot.create.step(dt_s, meas)

    # ------------------------------------------------------------------ sensing

    def laser_pose(self, name: str) -> Tuple[float, float, float]:
        """Map pose (x, y, yaw) of a robot's laser."""
        r = self._by_name[name]
        m = self.model
        c, s = math.cos(r.yaw), math.sin(r.yaw)
        return (r.x + c * m.laser_x_m - s * m.laser_y_m, r.y + s * m.laser_x_m + c * m.laser_y_m,
                r.yaw + m.laser_yaw_rad)

    def scan_circles(self, name: str) -> np.ndarray:
        """Everything round the laser of robot ``name`` can see: static circles, the other
        robots and the people (K, 3)."""
        dynamic = np.array(self._dynamic_circles(self._by_name[name]),
                           dtype=np.float64).reshape(-1, 3)
        return np.concatenate((self._static_circles, dynamic), axis=0)

    def scan(self, name: str) -> np.ndarray:
        """One noisy URG-04LX scan of robot ``name`` (LaserScan ``ranges``).

        Its noise is drawn from a generator keyed by (seed, robot, step), so a scan does
        not depend on which scans were taken before: skipping scans nobody listens to
        keeps runs deterministic."""
        r = self._by_name[name]
        x, y, yaw = self.laser_pose(name)
        rng = np.random.default_rng([self.seed, 1 + r.index, self.steps])
        return self.laser.scan(x, y, yaw, self.scan_circles(name), rng)

    def true_scan(self, name: str) -> np.ndarray:
        """Noise-free ranges (+inf for no return) of robot ``name``'s laser."""
        x, y, yaw = self.laser_pose(name)
        return self.laser.true_ranges(x, y, yaw, self.scan_circles(name))[0]


def select_robots(world: World, namespaces: Sequence[str]) -> List[RobotSpec]:
    """The world's robots whose namespaces are listed ('/' or '' = the un-namespaced
    robot); all robots when the list is empty. Raises KeyError naming a missing one."""
    wanted = [ns.strip("/") for ns in namespaces]
    if not wanted:
        return list(world.robots)
    by_ns = {r.namespace: r for r in world.robots}
    missing = [ns or "/" for ns in wanted if ns not in by_ns]
    if missing:
        raise KeyError("world %s has no robot with namespace %s (it has: %s)"
                       % (world.path, ", ".join(missing),
                          ", ".join(r.namespace or "/" for r in world.robots)))
    return [by_ns[ns] for ns in wanted]
