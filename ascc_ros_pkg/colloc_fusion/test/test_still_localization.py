"""Localization of robots that stand still (the benchmark's robots), offline: the cloud's
mean keeps centimetres of error, the scan-matched refinement removes most of it (not a
wrong convergence). Judged on
placements drawn with a seed used nowhere else (the benchmark uses seeds 1-3)."""
import os

import numpy as np
import yaml

from ascc_common.params import from_params
from ascc_navigation import mcl
from ascc_sim.world import load_world
from colloc_fusion.bench import random_placement, write_placement_world
from colloc_fusion.still_localization import still_robot_errors

HERE = os.path.dirname(os.path.abspath(__file__))
WORLD = os.path.join(HERE, "..", "..", "ascc_sim", "worlds", "three_robots.yaml")
AMCL_YAML = os.path.join(HERE, "..", "..", "ascc_navigation", "config", "amcl.yaml")


def test_refinement_beats_the_still_cloud_on_held_out_placements(tmp_path):
    with open(AMCL_YAML) as f:
        params = from_params(mcl.MclParams, yaml.safe_load(f).get)
    world = load_world(WORLD)
    rng = np.random.default_rng(41)
    plain, refined = [], []
    for k in range(3):
        p = random_placement(world.grid, rng, (0.3, 0.3, 8.2, 6.7))
        w = load_world(write_placement_world(str(tmp_path / ("w%d.yaml" % k)), p, WORLD))
        for err in still_robot_errors(w, p, params, nomotion_updates=10, seed=k).values():
            plain.append(err["mcl"])
            refined.append(err["refined"])
    plain, refined = np.array(plain), np.array(refined)
    d_plain = np.hypot(plain[:, 0], plain[:, 1])
    d_ref = np.hypot(refined[:, 0], refined[:, 1])
    assert len(d_ref) == 9
    # the refinement is local: it cannot repair a cloud that converged to the wrong place
    # (with these seeds one robot's cloud is 0.9 m off; the fusion's gate is for that)
    assert np.sum(d_ref < d_plain) >= 7
    assert np.median(d_ref) < 0.3 * np.median(d_plain)
    assert np.median(d_ref) < 0.01 and np.median(np.abs(refined[:, 2])) < np.deg2rad(0.3)
    assert np.all(np.hypot(*(refined - plain)[:, :2].T) <= params.refine_max_shift_m + 1e-9)
