"""The SLAM-map calibration (thesis 3.4.1 with a map in its own frame): the office mapped
by the gmapping stand-in from a drive that starts turned and away from the truth's
origin; the desk corners measured in that map give a transform that is not the identity,
close to the exact one, with a residual of a few centimetres."""
import math
import os

import numpy as np
import yaml

from ascc_sim.world import load_world
from colloc_fusion import slam_map

HERE = os.path.dirname(os.path.abspath(__file__))
WORLD = os.path.join(HERE, "..", "..", "ascc_sim", "worlds", "three_robots.yaml")
GMAPPING_YAML = os.path.join(HERE, "..", "..", "ascc_navigation", "config", "gmapping.yaml")


def test_calibration_in_a_slam_map():
    world = load_world(WORLD)
    with open(GMAPPING_YAML) as f:
        params = yaml.safe_load(f)
    grid, info, fit, exact, failed = slam_map.calibrated_map(world, params, seed=3)
    assert failed == {}
    assert abs(exact.theta) > 1.0  # the map frame is turned against the truth's
    assert abs(math.remainder(fit.theta - exact.theta, 2 * math.pi)) < 0.02
    assert fit.rms_m < 0.1 and len(fit.residuals_m) == 4
    corners = np.array([(o.pose.x, o.pose.y) for o in world.objects if o.type == "landmark"])
    assert np.all(np.hypot(*(fit.apply(corners) - exact.apply(corners)).T) < 0.15)
    # the map holds the office: about 8.5 m x 7 m of known cells
    known = np.count_nonzero(grid >= 0) * info.resolution ** 2
    assert 40.0 < known < 70.0
