"""The simulator's main loop without ROS: fixed-step physics, byte exchange with the
virtual Creates' serial links, periodic outputs in simulated time, real-time pacing.

Outputs are callbacks (the node turns them into ROS messages), the wall clock and the
sleep are injectable, so the loop is tested without a master or real time passing.
"""
from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any, Callable, Dict, List, Optional

from ascc_common.params import nested, param

from .laser import LaserConfig
from .sim import RobotModel, Simulation

CATCH_UP_LIMIT_S = 0.5  # wall-clock lag beyond which pacing stops trying to catch up [s]


@dataclass
class SimulatorParams:
    """Everything the simulator node reads (private parameters), the robot and laser
    models under ``~robot/*`` and ``~laser/*`` (names they do not declare are errors)."""

    world: Optional[str] = param(None, "path of the world YAML (required)")
    robots: str = param("", "space-separated namespaces of the robots to simulate (\"\": "
                            "all, /: the one without namespace)")
    real_time_factor: float = param(1.0, "cap on simulated/wall time; 0: as fast as possible")
    seed: int = param(0, "seed of every random draw")
    publish_map_to_odom: bool = param(False, "static map -> <ns>/odom = start pose")
    publish_laser_mount: bool = param(True, "static <ns>/base_link -> <ns>/laser (the "
                                            "laser mount of ~robot); false when a robot "
                                            "description publishes the laser's frame")
    link_dir: Optional[str] = param(None, "directory of the pty links (unset: "
                                          "/tmp/ascc_sim_<pid>)")
    physics_dt_s: float = param(0.01, "[s] physics step", gt=0.0)
    clock_period_s: Optional[float] = param(None, "[s] /clock period (unset: physics_dt_s)",
                                            gt=0.0)
    wait_for_drivers_s: float = param(30.0, "[s wall] hold the clock until the drivers "
                                            "opened their links, at most this long")
    wait_for_scan_subscribers: bool = param(False, "also hold it until every scan has a "
                                                   "subscriber")
    wait_for_publishers: str = param("", "also hold it until each of these topics "
                                         "(space-separated) has a publisher")
    max_sim_time_s: float = param(0.0, "[s] stop after this much simulated time; 0: never")
    stats_file: str = param("", "write run statistics (JSON) there at the end")
    ground_truth_rate_hz: float = param(20.0, "[Hz] ground truth poses, people", gt=0.0)
    marker_rate_hz: float = param(2.0, "[Hz] markers", gt=0.0)
    map_frame: str = param("map", "frame of the ground truth")
    robot: RobotModel = nested(RobotModel, "robot/", closed=True)
    laser: LaserConfig = nested(LaserConfig, "laser/", closed=True)

    def clock_period(self) -> float:
        """The /clock period [s]: ``clock_period_s``, unset: ``physics_dt_s``."""
        return self.physics_dt_s if self.clock_period_s is None else self.clock_period_s


class Periodic:
    """Fires every ``period_s`` of simulated time (quantised to the physics step; the
    average rate is exact). ``offset_s`` shifts the phase to spread work over steps."""

    def __init__(self, period_s: float, callback: Callable[[float], None],
                 offset_s: float = 0.0):
        if not period_s > 0:
            raise ValueError("period must be > 0")
        self.period_s = float(period_s)
        self.callback = callback
        self.next_s = float(offset_s)

    def poll(self, t_s: float) -> bool:
        if t_s + 1e-9 < self.next_s:
            return False
        self.callback(t_s)
        self.next_s += self.period_s
        if self.next_s <= t_s:  # fell behind by more than a period: skip, do not burst
            self.next_s = t_s + self.period_s
        return True


class SimRunner:
    """Steps ``sim`` by ``dt_s``: physics, then the serial links (the sensor frames of
    this step go out, the commands that came in act from the next step), then the
    periodic outputs that fell due.

    Args:
        sim: the simulation core.
        links: robot name -> serial link with ``pump()`` (PtyLink), pumped every step.
        dt_s: physics step [s of simulated time].
        real_time_factor: cap on simulated/wall time; 0 = as fast as possible.
        max_sim_time_s: stop after this much simulated time (0 = never).
    """

    def __init__(self, sim: Simulation, links: Dict[str, Any], dt_s: float,
                 real_time_factor: float = 1.0, max_sim_time_s: float = 0.0,
                 wall_clock: Callable[[], float] = time.monotonic,
                 sleep: Callable[[float], None] = time.sleep,
                 cpu_clock: Callable[[], float] = time.process_time,
                 epoch_clock: Callable[[], float] = time.time):
        if not dt_s > 0:
            raise ValueError("dt_s must be > 0")
        if real_time_factor < 0:
            raise ValueError("real_time_factor must be >= 0 (0 = as fast as possible)")
        self.sim = sim
        self.links = links
        self.dt_s = float(dt_s)
        self.real_time_factor = float(real_time_factor)
        self.max_sim_time_s = float(max_sim_time_s)
        self._wall = wall_clock
        self._sleep = sleep
        self._cpu = cpu_clock
        self._epoch = epoch_clock
        self.cpu_start = 0.0
        # epoch time minus simulated time at the pace's reference: stamp_s() (wall-clock mode)
        self.epoch_offset_s = 0.0
        self.periodics: List[Periodic] = []
        self.steps = 0
        self.wall_start: Optional[float] = None
        self._pace_wall0 = 0.0
        self._pace_sim0 = 0.0
        self.catch_up_resets = 0  # times pacing gave up catching up (the host was too slow)

    def every(self, period_s: float, callback: Callable[[float], None],
              offset_s: float = 0.0) -> Periodic:
        p = Periodic(period_s, callback, offset_s)
        self.periodics.append(p)
        return p

    @property
    def time_s(self) -> float:
        return self.sim.time_s

    @property
    def done(self) -> bool:
        return 0.0 < self.max_sim_time_s <= self.sim.time_s + 1e-9

    def start(self) -> None:
        """Fire the outputs due at t = 0 (clock, first scans, latched ground truth)."""
        now = self._wall()
        self.cpu_start = self._cpu()
        self.wall_start = self._pace_wall0 = now
        self._pace_sim0 = self.sim.time_s
        self.epoch_offset_s = self._epoch() - self.sim.time_s
        for p in self.periodics:
            p.poll(self.sim.time_s)

    def step(self) -> None:
        """One physics step and whatever outputs fall due."""
        if self.wall_start is None:
            self.start()
        self.sim.step(self.dt_s)
        for link in self.links.values():
            link.pump()
        self.steps += 1
        t = self.sim.time_s
        for p in self.periodics:
            p.poll(t)
        self._pace()

    def _pace(self) -> None:
        if self.real_time_factor <= 0:
            return
        target = self._pace_wall0 + (self.sim.time_s - self._pace_sim0) / self.real_time_factor
        now = self._wall()
        if target > now:
            self._sleep(target - now)
        elif now - target > CATCH_UP_LIMIT_S:
            # Far behind (slow host, suspended process): restart pacing from here instead
            # of running flat out until the lost time is made up.
            self._pace_wall0, self._pace_sim0 = now, self.sim.time_s
            self.epoch_offset_s += now - target  # the time lost: stamps stay on the wall clock
            self.catch_up_resets += 1

    def stamp_s(self, t_s: float) -> float:
        """Simulated time t_s on the wall clock (epoch seconds) for a simulation paced at a
        real-time factor of 1 that runs on the wall clock instead of /clock: the epoch time
        at start() plus the simulated time since, plus the time lost whenever pacing gave up
        catching up. At other factors the two clocks part: the node refuses that mode."""
        return self.epoch_offset_s + t_s

    def achieved_real_time_factor(self) -> float:
        """Simulated time over wall time since start()."""
        if self.wall_start is None:
            return 0.0
        wall = self._wall() - self.wall_start
        return self.sim.time_s / wall if wall > 0 else 0.0

    def stats(self) -> Dict[str, Any]:
        out: Dict[str, Any] = {
            "sim_time_s": self.sim.time_s,
            "wall_time_s": (self._wall() - self.wall_start) if self.wall_start else 0.0,
            "steps": self.steps,
            "real_time_factor_cap": self.real_time_factor,
            "achieved_real_time_factor": self.achieved_real_time_factor(),
            # CPU time of this process (all its threads) since start(): sim time over it
            # is the real-time factor the process would reach with a core of its own.
            "cpu_time_s": self._cpu() - self.cpu_start,
            "catch_up_resets": self.catch_up_resets,
            "robots": {},
        }
        for r in self.sim.robots:
            link = self.links.get(r.name)
            out["robots"][r.name] = {
                "distance_m": r.distance_m,
                "bytes_from_driver": getattr(link, "bytes_in", 0),
                "bytes_to_driver": getattr(link, "bytes_out", 0),
                "dropped_bytes": getattr(link, "dropped_bytes", 0),
                "frames_sent": getattr(r.create, "frames_sent", 0),
            }
        return out
