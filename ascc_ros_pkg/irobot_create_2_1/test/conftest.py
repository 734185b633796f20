"""Fixtures shared by the virtual Create's tests (test_oi_commands, test_create_state,
test_oi_sensors, test_virtual_create, test_pty_link): each returns a helper function."""

import pytest

from irobot_create_2_1 import protocol as oi
from irobot_create_2_1.virtual_create import VirtualCreate


def _started(mode=oi.safe, **kwargs):
    create = VirtualCreate(**kwargs)
    create.feed(oi.start() + mode())
    return create


def _query(create, *pids):
    create.read_output()
    create.feed(oi.query_list(list(pids)))
    return oi.decode_packets(list(pids), create.read_output())


def _run(create, seconds, dt=0.005):
    for _ in range(int(round(seconds / dt))):
        create.step(dt)


def _collect_frames(create, seconds, dt):
    parser = oi.StreamParser()
    frames = []
    for _ in range(int(round(seconds / dt))):
        create.step(dt)
        frames += parser.feed(create.read_output())
    return frames, parser


@pytest.fixture
def started():
    """started(mode=oi.safe, **kwargs): a VirtualCreate(**kwargs) after Start and `mode`."""
    return _started


@pytest.fixture
def query():
    """query(create, *pids): {packet id: value} of a Query List of `pids`."""
    return _query


@pytest.fixture
def run():
    """run(create, seconds, dt=0.005): step emulated time in steps of dt [s]."""
    return _run


@pytest.fixture
def collect_frames():
    """collect_frames(create, seconds, dt): (stream frames decoded meanwhile, parser)."""
    return _collect_frames
