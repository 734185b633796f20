"""bench_mapper.py's average of several filters' lineages (``--filters``): positions
averaged, headings averaged on the circle (no ROS master needed)."""
import math
import os
import sys

import numpy as np
import pytest

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "scripts"))
import bench_mapper  # noqa: E402


def test_average_of_lineages_is_pose_by_pose():
    a = np.array([[0.0, 0.0, 0.1], [1.0, 0.0, 0.2]])
    b = np.array([[0.2, 0.4, 0.3], [1.4, -0.2, 0.0]])
    avg = bench_mapper.average_lineages([a, b])
    assert avg.shape == (2, 3)
    assert avg[:, :2] == pytest.approx(np.array([[0.1, 0.2], [1.2, -0.1]]))
    assert avg[:, 2] == pytest.approx([0.2, 0.1])
    assert a[0, 2] == 0.1  # the inputs are not changed


def test_headings_either_side_of_pi_average_to_pi():
    a = np.array([[0.0, 0.0, math.pi - 0.1]])
    b = np.array([[0.0, 0.0, -math.pi + 0.1]])
    heading = bench_mapper.average_lineages([a, b])[0, 2]
    # the arithmetic mean would be 0, the opposite direction
    assert abs(math.remainder(heading - math.pi, 2 * math.pi)) < 1e-9
