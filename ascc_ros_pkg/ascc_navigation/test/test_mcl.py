"""Tests of the Monte Carlo localizer (pure code, no ROS master)."""

import numpy as np
import pytest

from ascc_common.grid import OCCUPIED, GridInfo
from ascc_common.params import from_params
from ascc_common.pose2d import compose, wrap_angle
from ascc_navigation import mcl
from ascc_navigation import synthetic as syn
from ascc_navigation.laser import LaserMount

MOUNT = LaserMount(0.1, 0.0, 0.0)


@pytest.fixture(scope="module")
def office():
    grid, info = syn.office_world()
    return grid, info


def _field(grid, info, sigma=0.05):
    return mcl.LikelihoodField(grid, info, sigma_hit=sigma, range_max=syn.URG_RANGE_MAX_M)


# The filter uses laser_max_beams (30) of a scan: simulating 121 of the URG's 683 beams
# keeps the tests fast without changing what the filter sees.
SPEC = syn.LaserSpec(increment=syn.URG_FOV_RAD / 120)


def _scan_points(grid, info, pose, rng, params):
    spec = SPEC
    r = syn.simulate_scan(grid == OCCUPIED, info, pose, MOUNT, spec, rng)
    return mcl.scan_endpoints(r, spec.angle_min, spec.angle_increment, MOUNT, spec.range_min,
                              spec.range_max, params.laser_max_beams)


def test_likelihood_field_peaks_at_the_wall_surface():
    grid = np.zeros((40, 40), np.int8)
    grid[:, 20:] = OCCUPIED  # wall surface at x = 1.0 m
    info = GridInfo(0.05, 40, 40)
    field = _field(grid, info, sigma=0.1)
    xs = np.array([0.5, 0.8, 0.9, 0.97, 1.0])
    lp = field.log_likelihood(np.column_stack([xs, np.full_like(xs, 1.0)]))
    assert np.all(np.diff(lp) > 0), lp  # closer to the surface: more likely
    # at the surface: within the step between the last free cell centre and the wall
    assert lp[-1] > field.log_p.max() - 0.025 ** 2 / (2 * 0.1 ** 2)
    off_map = field.log_likelihood(np.array([[-5.0, 1.0], [1.0, 99.0]]))
    assert np.allclose(off_map, field.log_p_outside)
    assert field.log_p_outside < lp.min()


def test_likelihood_field_rejects_mismatched_grid():
    with pytest.raises(ValueError):
        mcl.LikelihoodField(np.zeros((10, 12), np.int8), GridInfo(0.05, 10, 10))


def test_scan_endpoints_drops_bad_beams_and_subsamples():
    ranges = np.array([1.0, np.nan, np.inf, 0.01, 5.0, 2.0, -np.inf, 3.0])
    pts = mcl.scan_endpoints(ranges, -np.pi / 2, np.pi / 7, LaserMount(), 0.02, 4.0, 10)
    assert len(pts) == 3  # 1.0, 2.0, 3.0 survive; 5.0 >= range_max is "no return"
    assert np.allclose(np.hypot(pts[:, 0], pts[:, 1]), [1.0, 2.0, 3.0])
    many = mcl.scan_endpoints(np.full(682, 2.0), -2.0, 4.0 / 681, LaserMount(), 0.02, 4.0, 30)
    assert len(many) == 30
    none = mcl.scan_endpoints(np.full(10, np.nan), -1.0, 0.2, LaserMount(), 0.02, 4.0, 30)
    assert none.shape == (0, 2)


def test_scan_endpoints_respects_the_mount():
    up = mcl.scan_endpoints([1.0], 0.5, 0.1, LaserMount(0.2, 0.0, 0.0), 0.0, 4.0, 30)
    down = mcl.scan_endpoints([1.0], 0.5, 0.1, LaserMount(0.2, 0.0, 0.0, True), 0.0, 4.0, 30)
    assert np.allclose(up[0], [0.2 + np.cos(0.5), np.sin(0.5)])
    assert np.allclose(down[0], [0.2 + np.cos(0.5), -np.sin(0.5)])


def test_motion_model_moves_particles_in_their_own_frame():
    params = mcl.MclParams(odom_alpha1=0.0, odom_alpha2=0.0, odom_alpha3=0.0, odom_alpha4=0.0)
    grid, info = np.zeros((20, 20), np.int8), GridInfo(0.1, 20, 20)
    loc = mcl.MonteCarloLocalizer(_field(grid, info), params, np.random.default_rng(0))
    loc.poses = np.array([[0.0, 0.0, 0.0], [1.0, 1.0, np.pi / 2]])
    loc.log_w = np.log([0.5, 0.5])
    loc.predict((5.0, 5.0, np.pi), (4.0, 5.0, np.pi - 0.3))  # 1 m forward, then turn -0.3
    assert np.allclose(loc.poses, [[1.0, 0.0, -0.3], [1.0, 2.0, np.pi / 2 - 0.3]], atol=1e-9)


def test_motion_noise_grows_with_alpha():
    grid, info = np.zeros((20, 20), np.int8), GridInfo(0.1, 20, 20)
    for alpha in (0.01, 0.2):
        params = mcl.MclParams(**{"odom_alpha%d" % i: alpha for i in range(1, 5)})
        loc = mcl.MonteCarloLocalizer(_field(grid, info), params, np.random.default_rng(1))
        loc.initialize_gaussian((0.0, 0.0, 0.0), np.eye(3) * 1e-12)
        loc.predict((0.0, 0.0, 0.0), (1.0, 0.0, 0.0))
        # 1 m straight: translation t ~ N(1, alpha), first rotation r ~ N(0, alpha);
        # x = t cos r has mean exp(-alpha/2), variance (1 + alpha)(1 + e^-2alpha)/2 - e^-alpha
        x = loc.poses[:, 0]
        assert x.mean() == pytest.approx(np.exp(-alpha / 2), abs=0.02)
        var = (1 + alpha) * (1 + np.exp(-2 * alpha)) / 2 - np.exp(-alpha)
        assert x.std() == pytest.approx(np.sqrt(var), rel=0.1)


def test_low_variance_resampling_follows_weights():
    rng = np.random.default_rng(2)
    assert set(mcl.low_variance_indices(np.array([0.0, 1.0, 0.0]), 50, rng)) == {1}
    idx = mcl.low_variance_indices(np.array([0.1, 0.6, 0.3]), 1000, rng)
    assert np.bincount(idx, minlength=3) / 1000 == pytest.approx([0.1, 0.6, 0.3], abs=0.002)


def test_kld_sample_count_grows_with_occupied_bins():
    n = mcl.kld_sample_count(np.array([1, 2, 10, 100, 1000]), 0.01, 0.99)
    assert n[0] == 0 and np.all(np.diff(n) > 0)
    assert n[3] > 4000  # amcl's formula: about (k - 1) / (2 err) for large k


def test_kld_resampling_adapts_the_particle_count():
    grid, info = np.zeros((200, 200), np.int8), GridInfo(0.1, 200, 200)
    params = mcl.MclParams(min_particles=100, max_particles=3000)
    loc = mcl.MonteCarloLocalizer(_field(grid, info), params, np.random.default_rng(3))
    loc.initialize_gaussian((10.25, 10.25, np.deg2rad(5.0)), np.diag([1e-4, 1e-4, 1e-4]))
    loc.resample()
    assert len(loc.poses) == 100  # one histogram bin (0.5 m, 0.5 m, 10 deg): the minimum
    loc.initialize_gaussian((10.0, 10.0, 0.0), np.diag([1e-4, 1e-4, 1e-4]))
    loc.resample()
    # straddling bin borders in x, y and yaw: k = 8 bins -> ceil(7 / 0.02 * x^3) = 525
    assert len(loc.poses) == 525
    loc.initialize_global()
    loc.resample()
    assert len(loc.poses) == 3000  # spread over the whole map: the maximum


def test_estimate_mean_and_covariance_with_yaw_wrap():
    grid, info = np.zeros((20, 20), np.int8), GridInfo(0.1, 20, 20)
    params = mcl.MclParams(max_particles=20000)
    loc = mcl.MonteCarloLocalizer(_field(grid, info), params, np.random.default_rng(4))
    cov = np.array([[0.04, 0.01, 0.0], [0.01, 0.09, 0.0], [0.0, 0.0, 0.01]])
    loc.initialize_gaussian((1.0, 1.0, np.pi - 0.05), cov)
    mean, est = loc.estimate()
    assert mean[:2] == pytest.approx([1.0, 1.0], abs=0.01)
    assert wrap_angle(mean[2] - (np.pi - 0.05)) == pytest.approx(0.0, abs=0.005)
    # spread of the cloud plus the cell term res^2 / 12 on x and y
    expected = cov + np.diag([0.01 / 12, 0.01 / 12, 0.0])
    assert est == pytest.approx(expected, abs=0.004)
    assert len(mcl.covariance_6x6(est)) == 36
    assert mcl.covariance_6x6(est)[35] == pytest.approx(est[2, 2])


def test_map_to_odom_puts_the_base_where_the_filter_says():
    pose_map = np.array([3.0, -1.0, 0.7])
    pose_odom = np.array([0.5, 2.0, -1.2])
    t = mcl.map_to_odom(pose_map, pose_odom)
    assert compose(t, pose_odom) == pytest.approx(pose_map)


def test_update_gating_and_reset():
    grid, info = syn.office_world()
    params = mcl.MclParams(update_min_d=0.2, update_min_a=0.5)
    loc = mcl.MonteCarloLocalizer(_field(grid, info), params, np.random.default_rng(5))
    rng = np.random.default_rng(6)
    pts = _scan_points(grid, info, (2.0, 2.0, 0.0), rng, params)
    assert not loc.process((0.0, 0.0, 0.0), pts)  # not initialised yet
    loc.initialize_gaussian((2.0, 2.0, 0.0), np.diag([0.01, 0.01, 0.01]))
    assert loc.process((0.0, 0.0, 0.0), pts)  # first scan: sensor update
    assert not loc.process((0.1, 0.0, 0.0), pts)  # 0.1 m: below update_min_d
    assert loc.process((0.25, 0.0, 0.0), pts)
    assert not loc.process((0.25, 0.0, 0.4), pts)
    assert loc.process((0.25, 0.0, 0.6), pts)
    loc.reset_odometry()
    assert loc.process((7.0, 7.0, 0.0), pts)  # after a reset: no motion update from (7, 7)
    assert loc.estimate()[0][:2] == pytest.approx([2.0, 2.0], abs=0.3)
    assert not loc.process((9.0, 7.0, 0.0), np.zeros((0, 2)))  # empty scan: no update


def test_params_from_mapping_casts_and_ignores_unknown_keys():
    p = from_params(mcl.MclParams, {"min_particles": 250.0, "laser_sigma_hit": "0.1",
                                    "use_map_topic": True}.get)
    assert p.min_particles == 250 and isinstance(p.min_particles, int)
    assert p.laser_sigma_hit == 0.1


def test_tracking_accuracy_and_honest_covariance(office):
    """A drive along the office loop: small error, the 2-sigma ellipse holds the truth."""
    grid, info = office
    params = mcl.MclParams(min_particles=500, update_min_d=0.1, update_min_a=0.2,
                           resample_interval=1, laser_sigma_hit=0.1, laser_beam_exponent=0.2)
    truth = syn.waypoint_trajectory(syn.office_loop_waypoints()[:5], v=0.3, dt=0.1)
    rng = np.random.default_rng(7)
    odom = syn.noisy_odometry(truth, rng)
    loc = mcl.MonteCarloLocalizer(_field(grid, info, 0.1), params, np.random.default_rng(8))
    loc.initialize_gaussian(truth[0] + [0.3, -0.2, 0.1], np.diag([0.25, 0.25, 0.0685]))
    errors, inside = [], []
    for k in range(len(truth)):
        if loc.process(odom[k], _scan_points(grid, info, truth[k], rng, params)):
            mean, cov = loc.estimate()
            d = truth[k, :2] - mean[:2]
            errors.append(np.hypot(*d))
            inside.append(d @ np.linalg.solve(cov[:2, :2], d) <= 4.0)
    errors, inside = np.array(errors[5:]), np.array(inside[5:])  # after convergence
    assert len(errors) > 50
    assert errors.mean() < 0.1
    assert inside.mean() >= 0.9


def test_global_localization_converges_in_an_asymmetric_room():
    """From particles spread over the whole free space (amcl's global_localization) to the
    true pose within a 4 m drive, in most runs: the room is asymmetric, but a short drive
    can still leave two places alike (a known limit of global localization)."""
    grid, info = syn.rect_world((7.0, 5.0), 0.05, [
        (1.0, 1.0, 1.6, 1.4), (4.5, 3.2, 5.5, 3.6), (6.0, 0.5, 6.4, 2.0), (2.5, 3.8, 2.8, 4.1)])
    truth = syn.waypoint_trajectory([(2.0, 2.5), (4.0, 2.5), (4.0, 1.5)], v=0.3, dt=0.1)
    # global localization needs amcl's wide default model (laser_sigma_hit 0.2): with the
    # sharper tracking model of config/amcl.yaml too few particles land near the truth
    params = mcl.MclParams(min_particles=500, max_particles=20000, update_min_d=0.1,
                           update_min_a=0.2, resample_interval=1, laser_sigma_hit=0.2)
    field = _field(grid, info, 0.2)
    converged = 0
    for seed in range(5):
        rng = np.random.default_rng(seed)
        odom = syn.noisy_odometry(truth, rng)
        loc = mcl.MonteCarloLocalizer(field, params, np.random.default_rng(seed + 100))
        loc.initialize_global()
        assert len(loc.poses) == 20000
        last = 0
        for k in range(len(truth)):
            if loc.process(odom[k], _scan_points(grid, info, truth[k], rng, params)):
                last = k
        mean, _ = loc.estimate()
        converged += np.hypot(*(mean[:2] - truth[last, :2])) < 0.1
        assert len(loc.poses) < 5000  # KLD shrank the cloud once it concentrated
    assert converged >= 4


def test_mcl_node_params_hold_the_filter_and_amcl_initial_pose_defaults():
    p = from_params(mcl.MclNodeParams, {"min_particles": 250, "initial_pose_x": 1}.get)
    assert p.filter.min_particles == 250 and p.initial_pose_x == 1.0
    assert p.initial_cov_aa == pytest.approx((np.pi / 12) ** 2) and p.seed == -1


def test_signed_surface_distance_crosses_zero_at_the_wall():
    grid = np.zeros((40, 40), np.int8)
    grid[:, 20:] = OCCUPIED  # wall surface at x = 1.0 m
    field = _field(grid, GridInfo(0.05, 40, 40), sigma=0.1)
    xs = np.array([0.8, 0.95, 1.0, 1.05, 1.2])
    d = field._bilinear(field.signed_dist, np.column_stack([xs, np.full_like(xs, 1.0)]), 9.0)
    assert d == pytest.approx(1.0 - xs, abs=1e-6)  # + in free space, - inside, 0 on it
    ll = field.surface_log_likelihood(np.column_stack([xs, np.full_like(xs, 1.0)]))
    assert np.argmax(ll) == 2 and ll[1] == pytest.approx(ll[3], abs=1e-6)


def test_refine_pose_recovers_an_offset_pose_with_many_beams(office):
    """The scan match moves a pose that is 8 cm and 2 deg off back to within 1.5 cm and
    0.3 deg, in several places of the office; a robot whose particles do not move cannot
    do this (see colloc_fusion.still_localization)."""
    grid, info = office
    field = _field(grid, info, 0.1)
    spec = syn.LaserSpec()  # all 683 beams: the refinement uses refine_max_beams of them
    rng = np.random.default_rng(11)
    for pose in [(2.0, 2.0, 0.3), (6.0, 6.5, -1.2), (3.0, 6.0, 2.5)]:
        r = syn.simulate_scan(grid == OCCUPIED, info, pose, MOUNT, spec, rng)
        pts = mcl.scan_endpoints(r, spec.angle_min, spec.angle_increment, MOUNT,
                                 spec.range_min, spec.range_max, 360)
        start = np.array(pose) + [0.06, -0.053, np.deg2rad(2.0)]
        refined, gain = mcl.refine_pose(field, start, pts)
        assert gain > 0.0
        assert np.hypot(*(refined[:2] - pose[:2])) < 0.015, (pose, refined)
        assert abs(wrap_angle(refined[2] - pose[2])) < np.deg2rad(0.3)


def test_refine_pose_stays_within_its_bounds(office):
    grid, info = office
    field = _field(grid, info, 0.1)
    spec = syn.LaserSpec()
    pose = (2.0, 2.0, 0.3)
    r = syn.simulate_scan(grid == OCCUPIED, info, pose, MOUNT, spec, np.random.default_rng(2))
    pts = mcl.scan_endpoints(r, spec.angle_min, spec.angle_increment, MOUNT, spec.range_min,
                             spec.range_max, 360)
    start = np.array([2.5, 2.0, 0.3])
    refined, _ = mcl.refine_pose(field, start, pts, max_shift_m=0.1, max_rot_rad=0.05)
    assert np.hypot(*(refined[:2] - start[:2])) <= 0.1 + 1e-9
    assert abs(refined[2] - start[2]) <= 0.05 + 1e-9
    same, gain = mcl.refine_pose(field, start, np.zeros((0, 2)))
    assert np.array_equal(same, start) and gain == 0.0


def test_refined_estimate_only_when_enabled(office):
    grid, info = office
    field = _field(grid, info, 0.1)
    spec = syn.LaserSpec()
    pose = (2.0, 2.0, 0.3)
    rng = np.random.default_rng(3)
    r = syn.simulate_scan(grid == OCCUPIED, info, pose, MOUNT, spec, rng)
    pts = mcl.scan_endpoints(r, spec.angle_min, spec.angle_increment, MOUNT, spec.range_min,
                             spec.range_max, 360)
    for enabled in (False, True):
        loc = mcl.MonteCarloLocalizer(field, mcl.MclParams(refine_estimate=enabled),
                                      np.random.default_rng(4))
        loc.initialize_gaussian((2.08, 1.95, 0.33), np.diag([1e-4, 1e-4, 1e-5]))
        mean, cov = loc.estimate()
        out, out_cov = loc.refined_estimate(pts)
        assert np.array_equal(out_cov, cov)  # the covariance stays the cloud's
        if enabled:
            assert np.hypot(*(out[:2] - pose[:2])) < 0.015
            assert loc.last_refinement[0] > 0.05
        else:
            assert np.array_equal(out, mean) and loc.last_refinement is None


def test_selective_resampling_keeps_the_cloud_while_the_weights_are_even():
    """amcl's selective_resampling: no resampling while the effective sample size is
    above half the particles (here: a map without obstacles, all weights equal)."""
    grid, info = np.zeros((40, 40), np.int8), GridInfo(0.05, 40, 40)
    pts = np.array([[1.0, 0.0], [0.0, 1.0]])
    for selective in (False, True):
        params = mcl.MclParams(max_particles=2000, min_particles=100, resample_interval=1,
                               selective_resampling=selective)
        loc = mcl.MonteCarloLocalizer(_field(grid, info), params, np.random.default_rng(9))
        loc.initialize_gaussian((1.0, 1.0, 0.0), np.diag([1e-4, 1e-4, 1e-4]))
        before = loc.poses.copy()
        assert loc.process((0.0, 0.0, 0.0), pts)
        if selective:
            assert np.array_equal(loc.poses, before)
        else:  # resampled: KLD shrinks a concentrated cloud
            assert len(loc.poses) < len(before)
