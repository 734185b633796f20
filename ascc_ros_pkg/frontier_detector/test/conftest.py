"""The compiled kernels are loaded (or, after a source change, compiled: a few seconds of
CPU) once per session, before the tests, so that no single test carries that cost."""

import pytest

from frontier_detector.goal_selection import warm_up


@pytest.fixture(scope="session", autouse=True)
def compiled_kernels():
    warm_up()
