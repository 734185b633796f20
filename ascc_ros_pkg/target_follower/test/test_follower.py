"""The follower's control law, limits, safety sector, search and stale inputs (no master)."""
import math

import numpy as np
import pytest

from ascc_common.params import ParamError, from_params
from target_follower.follower import (
    BLOCKED,
    FOLLOWING,
    LOST,
    SEARCHING,
    STALE,
    Aim,
    Follower,
    FollowerParams,
    SafetySector,
    control_law,
)

DT = 0.1  # [s] control period of these tests
# a Hokuyo URG-04LX-like layout: 240 deg, 0.36 deg per beam, mounted 0.05 m ahead of centre
# (as ascc_sim's); the safety sector then spans atan2(0.165, -0.05) = +-107 deg
N_BEAMS = 667
ANGLES = np.linspace(-math.radians(120), math.radians(120), N_BEAMS)
MOUNT = (0.05, 0.0)
RANGE_MIN, RANGE_MAX = 0.02, 5.6


def scan_with(points=(), base=np.inf):
    """Ranges from MOUNT of a world with only ``points`` (base_link, 3 cm posts)."""
    r = np.full(N_BEAMS, base, dtype=float)
    for px, py in points:
        dx, dy = px - MOUNT[0], py - MOUNT[1]
        d = math.hypot(dx, dy)
        half = math.atan2(0.03, d)
        on = np.abs(np.angle(np.exp(1j * (ANGLES - math.atan2(dy, dx))))) <= half
        r[on] = np.minimum(r[on], d)
    return r


def run(f, steps, aim, t0=0.0, blocked=False):
    """``steps`` fresh-input cycles toward ``aim``; the commands."""
    out = []
    for k in range(steps):
        now = t0 + k * DT
        out.append(f.step(now, DT, now, aim, now, blocked, "test"))
    return out


def test_turns_toward_the_target_and_centres_it():
    p = FollowerParams()
    left = control_law(p, Aim(math.radians(30), 1.2))
    right = control_law(p, Aim(math.radians(-30), 1.2))
    assert left[1] > 0.3 and right[1] == pytest.approx(-left[1])
    assert control_law(p, Aim(0.0, 1.2)) == (0.0, 0.0)
    # simulate a robot turning with its command: the bearing goes to zero
    f, bearing = Follower(p), 1.0
    for k in range(60):
        cmd = f.step(k * DT, DT, k * DT, Aim(bearing, 1.2), k * DT, False)
        bearing -= cmd.w * DT
    assert abs(bearing) < 0.02 and abs(cmd.w) < 0.05


def test_drives_to_the_set_distance_and_stops_in_the_band():
    p = FollowerParams()
    f, r = Follower(p), 4.0
    for k in range(200):
        cmd = f.step(k * DT, DT, k * DT, Aim(0.0, r), k * DT, False)
        assert cmd.state == FOLLOWING and 0.0 <= cmd.v <= p.max_linear_mps
        r -= cmd.v * DT
    assert abs(r - p.distance_m) <= p.distance_tolerance_m + 1e-6
    assert cmd.v == 0.0
    assert control_law(p, Aim(0.0, p.distance_m + 0.09))[0] == 0.0
    assert control_law(p, Aim(0.0, p.distance_m + 0.5))[0] > 0.0


def test_feedforward_keeps_pace_with_a_walking_target_without_a_standing_lag():
    p = FollowerParams()
    walk = 0.3  # [m/s] the target walks straight away from the robot
    for params in (p, FollowerParams(k_feedforward=0.0)):
        f, r = Follower(params), params.distance_m
        for k in range(600):  # 60 s
            cmd = f.step(k * DT, DT, k * DT, Aim(0.0, r, range_rate_mps=walk), k * DT, False)
            r += (walk - cmd.v) * DT
        if params is p:
            assert abs(r - p.distance_m) <= p.distance_tolerance_m
            assert cmd.v == pytest.approx(walk, abs=0.02)
        else:  # a proportional law alone lags by walk / k_v, beyond the band
            assert r - params.distance_m == pytest.approx(walk / params.k_linear_per_s,
                                                          abs=0.02)
    # a standing target's velocity noise does not make the robot creep inside the band
    assert control_law(p, Aim(0.0, p.distance_m, range_rate_mps=0.03))[0] == 0.0
    # a target coming closer does not add a reverse speed
    assert control_law(p, Aim(0.0, p.distance_m, range_rate_mps=-0.3))[0] == 0.0


def test_a_searching_aim_drives_in_the_searching_state_until_the_search_times_out():
    p = FollowerParams()
    f = Follower(p)
    cmd = f.step(0.0, DT, 0.0, Aim(0.0, 3.0), 0.0, False)
    assert cmd.state == FOLLOWING
    t = DT
    while t < p.search_timeout_s - DT:
        cmd = f.step(t, DT, t, Aim(0.1, 3.0, searching=True), t, False)
        assert cmd.state == SEARCHING
        t += DT
    assert cmd.v > 0.0  # it drives to where the target was last seen
    cmd = f.step(p.search_timeout_s + DT, DT, t, Aim(0.1, 3.0, searching=True), t, False)
    assert cmd.state == LOST and cmd.v == 0.0
    f.reset()
    f.step(0.0, DT, 0.0, Aim(0.0, 3.0), 0.0, False)
    cmd = f.step(DT, DT, DT, Aim(0.0, 3.0, searching=True), DT, True, "wall")
    assert cmd.state == SEARCHING and cmd.v <= 0.0 and cmd.reason == "wall"


def test_no_reversing_beyond_the_back_off_unless_allowed():
    p = FollowerParams()
    assert control_law(p, Aim(0.0, 0.3))[0] == pytest.approx(-p.backoff_mps)
    rev = from_params(FollowerParams, {"allow_reverse": True}.get)
    assert control_law(rev, Aim(0.0, 0.3))[0] == pytest.approx(-rev.max_linear_mps)
    never = from_params(FollowerParams, {"backoff_mps": 0.0}.get)
    assert control_law(never, Aim(0.0, 0.3))[0] == 0.0


def test_no_forward_speed_when_the_target_is_far_off_centre():
    p = FollowerParams()
    v0 = control_law(p, Aim(0.0, 3.0))[0]
    v_half = control_law(p, Aim(p.max_drive_bearing_rad / 2, 3.0))[0]
    assert v0 == pytest.approx(p.max_linear_mps)
    assert v_half == pytest.approx(v0 / 2)
    assert control_law(p, Aim(p.max_drive_bearing_rad + 0.1, 3.0))[0] == 0.0
    assert control_law(p, Aim(-2.0, 3.0)) == (0.0, -p.max_angular_radps)


def test_range_from_size_without_a_range():
    p = from_params(FollowerParams, {"area_at_distance_px": 4000.0}.get)
    assert control_law(p, Aim(0.0, math.nan, 4000.0))[0] == 0.0  # at the set distance
    assert control_law(p, Aim(0.0, math.nan, 1000.0))[0] > 0.0  # far (twice as far)
    assert control_law(p, Aim(0.0, math.nan, 16000.0))[0] < 0.0  # too close
    unset = FollowerParams()
    assert control_law(unset, Aim(0.3, math.nan, 1000.0))[0] == 0.0  # turn only
    assert control_law(unset, Aim(0.3, math.nan, 1000.0))[1] > 0.0


def test_speed_and_acceleration_limits():
    p = FollowerParams()
    f = Follower(p)
    cmds = run(f, 40, Aim(0.5, 10.0))
    v = np.array([c.v for c in cmds])
    w = np.array([c.w for c in cmds])
    assert v.max() <= p.max_linear_mps + 1e-9 and np.abs(w).max() <= p.max_angular_radps
    assert np.diff(np.r_[0.0, v]).max() <= p.max_linear_accel_mps2 * DT + 1e-9
    assert np.abs(np.diff(np.r_[0.0, w])).max() <= p.max_angular_accel_radps2 * DT + 1e-9
    assert v[-1] == pytest.approx(control_law(p, Aim(0.5, 10.0))[0])
    # a target suddenly on the other side: the turn rate reverses no faster than allowed
    w2 = np.array([c.w for c in run(f, 20, Aim(-0.5, 10.0), t0=4.0)])
    assert np.abs(np.diff(np.r_[w[-1], w2])).max() <= p.max_angular_accel_radps2 * DT + 1e-9


def test_stale_target_or_scan_stops_at_once():
    p = FollowerParams()
    f = Follower(p)
    run(f, 30, Aim(0.3, 3.0))
    assert f.v > 0.1
    now = 3.0
    cmd = f.step(now, DT, now - p.target_timeout_s - 0.01, Aim(0.3, 3.0), now, False)
    assert (cmd.v, cmd.w, cmd.state) == (0.0, 0.0, STALE) and "target" in cmd.reason
    run(f, 30, Aim(0.3, 3.0), t0=now)
    now = 6.0
    cmd = f.step(now, DT, now, Aim(0.3, 3.0), now - p.scan_timeout_s - 0.01, False)
    assert (cmd.v, cmd.w, cmd.state) == (0.0, 0.0, STALE) and "scan" in cmd.reason
    assert f.step(now, DT, None, None, now, False).state == STALE  # nothing yet
    assert f.step(now, DT, now, None, None, False).state == STALE


def test_blocked_stops_forward_motion_at_once_but_still_turns():
    f = Follower(FollowerParams())
    run(f, 30, Aim(0.2, 3.0))
    cmd = f.step(3.0, DT, 3.0, Aim(0.2, 3.0), 3.0, True, "obstacle")
    assert cmd.state == BLOCKED and cmd.v == 0.0 and cmd.w > 0.0
    back = f.step(3.1, DT, 3.1, Aim(0.0, 0.5), 3.1, True, "obstacle")
    assert back.state == FOLLOWING and back.v < 0.0  # backing off is not blocked


def test_search_toward_the_last_bearing_then_stop():
    p = FollowerParams()
    f = Follower(p)
    assert f.step(0.0, DT, 0.0, None, 0.0, False).state == LOST  # nothing acquired yet
    run(f, 10, Aim(-0.4, 1.2))
    t0 = 1.0
    cmds = [f.step(t0 + k * DT, DT, t0 + k * DT, None, t0 + k * DT, False)
            for k in range(int(p.search_timeout_s / DT) + 5)]
    searching = [c for c in cmds if c.state == SEARCHING]
    assert len(searching) == pytest.approx(p.search_timeout_s / DT, abs=1)
    assert all(c.v == 0.0 and c.w < 0.0 for c in searching[1:])
    assert min(c.w for c in searching) == pytest.approx(-p.search_angular_radps)
    assert cmds[-1].state == LOST and (cmds[-1].v, cmds[-1].w) == (0.0, 0.0)
    # found again: following, and a later loss searches for the full time again
    assert f.step(20.0, DT, 20.0, Aim(0.4, 1.2), 20.0, False).state == FOLLOWING
    assert f.step(20.1, DT, 20.1, None, 20.1, False).state == SEARCHING


def test_braking_distance_must_fit_in_the_stop_distance():
    with pytest.raises(ParamError, match="braking"):
        from_params(FollowerParams, {"stop_distance_m": 0.05}.get)


# -- the laser safety sector ------------------------------------------------------------

def sector(**overrides):
    return SafetySector(from_params(FollowerParams, overrides.get), ANGLES, MOUNT)


@pytest.mark.parametrize("mount_x", [0.1, -0.1, 0.0])
@pytest.mark.parametrize("radius", [0.165, 0.3])
def test_sector_is_sized_from_the_footprint_not_a_fixed_angle(mount_x, radius):
    p = from_params(FollowerParams, {"robot_radius_m": radius}.get)
    s = SafetySector(p, ANGLES, (mount_x, 0.0))
    # a beam leaving the footprint ahead of the centre (x > 0) enters the swept region;
    # the sector's edges are the rays from the mount to the footprint's sides (0, +-R)
    edge = math.atan2(radius, -mount_x)
    inside = np.abs(ANGLES) < edge - 0.02
    outside = np.abs(ANGLES) > edge + 0.02
    assert s.in_sector[inside].all() and not s.in_sector[outside].any()


def test_obstacle_in_the_path_blocks_one_beside_it_does_not():
    s = sector()
    free, _ = s.check(scan_with(), RANGE_MIN, RANGE_MAX)
    assert not free
    for point in [(0.4, 0.0), (0.25, 0.12), (0.45, -0.05)]:
        blocked, why = s.check(scan_with([point]), RANGE_MIN, RANGE_MAX)
        assert blocked and "obstacle" in why, point
    for point in [(0.3, 0.4), (0.0, -0.3), (0.5, 0.0), (0.9, 0.0), (-0.3, 0.0)]:
        blocked, why = s.check(scan_with([point]), RANGE_MIN, RANGE_MAX)
        assert not blocked, (point, why)


def test_a_curved_path_is_checked_along_its_arc():
    """A post ahead and to the right blocks the straight path and a right turn, not a left
    turn that passes it (a robot turning through a door past its frame)."""
    s = sector()
    r = scan_with([(0.35, -0.15)])
    assert s.check(r, RANGE_MIN, RANGE_MAX)[0]  # straight ahead (default)
    assert s.check(r, RANGE_MIN, RANGE_MAX, 0.0, 0.3)[0]
    assert not s.check(r, RANGE_MIN, RANGE_MAX, 2.0, 0.3)[0]  # left, 0.5 m radius
    assert s.check(r, RANGE_MIN, RANGE_MAX, -2.0, 0.3)[0]  # right
    # a shorter path stops before the post: only the length decides then
    assert not s.check(r, RANGE_MIN, RANGE_MAX, 0.0, 0.1)[0]
    # the arc's swept region against its definition: within R of a point of the arc
    k, length = 1.5, 0.3
    xy = np.random.default_rng(3).uniform([-0.1, -0.6], [0.7, 0.6], (2000, 2))
    arc = np.linspace(0.0, length, 3001)
    ax, ay = np.sin(k * arc) / k, (1.0 - np.cos(k * arc)) / k
    d = np.hypot(xy[:, :1] - ax, xy[:, 1:] - ay).min(axis=1)
    got = s.in_swept(xy[:, 0], xy[:, 1], k, length)
    clear = np.abs(d - s.radius) > 1e-3  # away from the boundary
    assert np.array_equal(got[clear], ((d <= s.radius) & (xy[:, 0] >= 0.0))[clear])


def test_follower_checks_the_commanded_arc_and_the_braking_path():
    p = FollowerParams()
    s = SafetySector(p, ANGLES, MOUNT)
    free = scan_with()
    f = Follower(p)
    for k in range(30):  # full speed toward a far target, nothing in the way
        f.step(k * DT, DT, k * DT, Aim(0.0, 5.0), k * DT,
               lambda c, d: s.check(free, RANGE_MIN, RANGE_MAX, c, d))
    assert f.v == pytest.approx(p.max_linear_mps)
    post = scan_with([(0.33, 0.0)])  # right ahead, within the braking path
    check = lambda c, d: s.check(post, RANGE_MIN, RANGE_MAX, c, d)  # noqa: E731
    # the target is to the left: the command is a tight left arc that misses the post, but
    # the robot still rolls straight on while it slows down: blocked, stopped at once
    cmd = f.step(3.0, DT, 3.0, Aim(0.6, 5.0), 3.0, check)
    assert cmd.state == BLOCKED and cmd.v == 0.0 and "obstacle" in cmd.reason
    assert cmd.w > 0.0  # turning is allowed
    # standing, the same tight arc is free: the robot drives it (straight ahead would not be)
    assert s.check(post, RANGE_MIN, RANGE_MAX)[0]
    cmd = f.step(3.1, DT, 3.1, Aim(0.6, 5.0), 3.1, check)
    assert cmd.state == FOLLOWING and cmd.v > 0.0
    # a target straight ahead: the commanded arc is the straight line: blocked
    f2 = Follower(p)
    cmd = f2.step(0.0, DT, 0.0, Aim(0.0, 5.0), 0.0, check)
    assert cmd.state == BLOCKED and cmd.v == 0.0


def test_rep117_ranges():
    s = sector()
    ahead = np.argmin(np.abs(ANGLES))
    side = np.argmin(np.abs(ANGLES - math.radians(115)))  # outside the sector
    r = scan_with(base=np.inf)  # +inf: nothing in range
    assert not s.check(r, RANGE_MIN, RANGE_MAX)[0]
    r = scan_with(base=RANGE_MAX + 1.0)  # beyond range_max: no object either
    assert not s.check(r, RANGE_MIN, RANGE_MAX)[0]
    r = scan_with()
    r[ahead] = -np.inf  # too close to measure, on a beam ahead
    blocked, why = s.check(r, RANGE_MIN, RANGE_MAX)
    assert blocked and "-inf" in why
    assert not s.in_sector[side]
    r = scan_with()
    r[side] = -np.inf  # ... beside: not in the path
    assert not s.check(r, RANGE_MIN, RANGE_MAX)[0]
    r = scan_with()
    r[s.in_sector] = np.nan  # a blind sector
    blocked, why = s.check(r, RANGE_MIN, RANGE_MAX)
    assert blocked and "blind" in why
    r = scan_with()
    r[np.flatnonzero(s.in_sector)[::3]] = np.nan  # a third invalid: still seeing
    r[ahead] = 0.01  # a finite value below range_min is invalid, not an obstacle
    assert not s.check(r, RANGE_MIN, RANGE_MAX)[0]
    assert s.check(r[:-1], RANGE_MIN, RANGE_MAX)[0]  # wrong layout: blocked, not a crash


def test_nan_ranges_raise_no_runtime_warning():
    """NaN beams are invalid, silently: numpy < 1.19 (Ubuntu 20.04's 1.17) warns on NaN
    comparisons, which would reach the robot's logs every scan (run under Python 3.8 with
    requirements-focal.txt by make test)."""
    import warnings

    r = scan_with()
    r[::4] = np.nan
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        sector().check(r, RANGE_MIN, RANGE_MAX)
