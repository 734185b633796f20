"""Tests of the virtual Create behind its pseudo-terminal (irobot_create_2_1.pty_link).

Expected values come from the iRobot Create Open Interface specification (sizes, bits,
special radii, 15 ms stream period, group layout) and from kinematics worked out here, not
from the emulator's own tables. No ROS master needed; `started`, `query`, `run` and
`collect_frames` are fixtures of conftest.py.
"""

import os
import threading
import time

import pytest
import serial

from irobot_create_2_1 import protocol as oi
from irobot_create_2_1.pty_link import PtyLink
from irobot_create_2_1.virtual_create import VirtualCreate


def wait_for(predicate, timeout_s=5.0):
    deadline = time.monotonic() + timeout_s
    while not predicate():
        if time.monotonic() > deadline:
            raise AssertionError("condition not met within %.1f s" % timeout_s)
        time.sleep(0.001)


def read_reply(link, port, n, timeout_s=5.0):
    got = bytearray()

    def done():
        link.pump()
        got.extend(port.read(n - len(got)))
        return len(got) >= n
    wait_for(done, timeout_s)
    return bytes(got)


@pytest.fixture
def link_path(tmp_path):
    return str(tmp_path / "ttyCreate")


def test_pty_end_to_end_with_pyserial(link_path):
    create = VirtualCreate()
    with PtyLink(create, link_path) as link:
        assert os.path.realpath(link.port) == link.tty_path
        with serial.Serial(link.port, 57600, timeout=0) as port:
            port.write(oi.start() + oi.safe() + oi.drive(200, oi.STRAIGHT_RADIUS)
                       + oi.sensors(6))
            reply = read_reply(link, port, 52)
            values = oi.decode_packets([6], reply)
            assert values[35] == 2 and values[39] == 200 and values[40] == -32768
            assert create.wheel_speed_cmd_mps == (0.2, 0.2)


def test_pty_is_raw_both_ways(link_path):
    """The host opens the port WITHOUT configuring it (plain os.open, unlike pyserial,
    which sets raw mode itself): every byte must pass unchanged, nothing may echo back."""
    special = bytes([0x0D, 0x0A, 0x03, 0x04, 0x11, 0x13, 0x1A, 0x7F, 0xFF, 0x00])

    class Recorder:
        def __init__(self):
            self.got = bytearray()

        def feed(self, data):
            self.got.extend(data)

        def read_output(self):
            return b""

    rec = Recorder()
    with PtyLink(rec, link_path) as link:
        host = os.open(link.port, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
        try:
            os.write(host, special)
            wait_for(lambda: link.pump() and len(rec.got) >= len(special))
            assert bytes(rec.got) == special       # no CR/LF translation, no signals
            assert link.inject(special) == len(special)
            got = bytearray()

            def host_read():
                try:
                    got.extend(os.read(host, 100))
                except BlockingIOError:
                    pass
                return len(got) >= len(special)
            wait_for(host_read)
            assert bytes(got) == special
            link.pump()
            assert bytes(rec.got) == special       # the robot's bytes were not echoed
        finally:
            os.close(host)


def test_reopen_keeps_the_symlink_and_drops_the_old_port(link_path):
    create = VirtualCreate()
    link = PtyLink(create, link_path)
    try:
        port = serial.Serial(link.port, 57600, timeout=0)
        link.reopen()
        assert link.port == link_path and os.path.realpath(link_path) == link.tty_path
        assert link.opens == 2
        with pytest.raises(serial.SerialException):   # the "unplugged" adapter is gone
            port.write(oi.start())
            port.read(1)
        port.close()
        with serial.Serial(link.port, 57600, timeout=0) as port2:
            port2.write(oi.start() + oi.sensors(35))
            assert read_reply(link, port2, 1) == bytes([1])
        link.close()
        assert not os.path.lexists(link_path)
        assert link.pump() == (0, 0)
    finally:
        link.close()


def test_stale_symlink_is_replaced_but_a_file_is_not(link_path, tmp_path):
    os.symlink("/dev/pts/does-not-exist", link_path)
    with PtyLink(VirtualCreate(), link_path) as link:
        assert os.readlink(link_path) == link.tty_path
    regular = str(tmp_path / "regular")
    with open(regular, "w") as handle:
        handle.write("keep me")
    with pytest.raises(FileExistsError):
        PtyLink(VirtualCreate(), regular)
    with open(regular) as handle:
        assert handle.read() == "keep me"


def test_no_blocking_when_nobody_reads(started):
    create = started()
    create.feed(oi.stream([6]))                    # 56-byte frame every 15 ms
    link = PtyLink(create)
    result = {}

    def flood():
        link.inject(bytes(1 << 20))                # 1 MiB of robot->host bytes
        for _ in range(4000):                      # 60 s of emulated stream
            create.step(0.015)
            link.pump()
        result["done"] = True

    worker = threading.Thread(target=flood, daemon=True)
    worker.start()
    worker.join(timeout=60.0)
    try:
        assert not worker.is_alive(), "pump() or inject() blocked"
        assert result.get("done")
        assert link.dropped_bytes > 0
        assert link.bytes_out + link.dropped_bytes == (1 << 20) + 4000 * 56
    finally:
        link.close()


def test_host_commands_reach_the_emulator_while_it_streams(link_path):
    create = VirtualCreate()
    with PtyLink(create, link_path) as link:
        with serial.Serial(link.port, 57600, timeout=0) as port:
            port.write(oi.start() + oi.full() + oi.stream([19]) + oi.drive_direct(100, 100))
            parser = oi.StreamParser([19])
            frames = []

            def enough():
                link.pump()
                create.step(0.015)
                link.pump()
                frames.extend(parser.feed(port.read(4096)))
                return len(frames) >= 100
            wait_for(enough, 20.0)
            assert parser.bad_checksum == 0
            assert all(f[19] in (1, 2) for f in frames[1:])   # 1.5 mm per frame, carried



class _SlowFeed:
    """An emulator whose feed() waits until told to go on (a pump caught mid-way)."""

    def __init__(self):
        self.inside = threading.Event()
        self.go_on = threading.Event()

    def feed(self, data):
        self.inside.set()
        self.go_on.wait(5.0)

    def read_output(self):
        return b"\x00" * 8


def test_close_from_another_thread_waits_for_a_pump_in_progress(link_path):
    # The simulator pumps its links in its own thread; a shutdown hook closes them. A close
    # between the pump's check of the descriptor and its next read gave
    # "TypeError: 'NoneType' object cannot be interpreted as an integer" in the pump.
    create = _SlowFeed()
    link = PtyLink(create, link_path)
    host = os.open(link.port, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
    try:
        os.write(host, b"\x80\x83")
        errors, result = [], []

        def pump():
            try:
                result.append(link.pump())
            except Exception as exc:  # noqa: BLE001 (the test reports it)
                errors.append(exc)
        worker = threading.Thread(target=pump)
        worker.start()
        assert create.inside.wait(5.0)
        closer = threading.Thread(target=link.close)
        closer.start()
        closer.join(0.2)
        assert closer.is_alive()          # the close waits for the pump ...
        create.go_on.set()
        worker.join(5.0)
        closer.join(5.0)
        assert errors == [] and result and result[0][0] == 2  # ... which ends cleanly
        assert not link.is_open and link.pump() == (0, 0)
    finally:
        create.go_on.set()
        os.close(host)
        link.close()


class _ClosingFeed:
    """An emulator whose feed() closes the link, as rospy's SIGINT handler does when it
    interrupts the simulator's own thread inside a pump (the lock is re-entrant)."""

    def __init__(self):
        self.link = None

    def feed(self, data):
        self.link.close()

    def read_output(self):
        return b"\x00" * 8


def test_close_from_a_signal_handler_inside_the_pump_ends_it_cleanly(link_path):
    # The CI logs showed the pump's TypeError at a rostest's shutdown after the lock above:
    # the close ran in the pumping thread itself, between two reads of the pump's loop.
    create = _ClosingFeed()
    link = PtyLink(create, link_path)
    create.link = link
    host = os.open(link.port, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
    try:
        os.write(host, b"\x80\x83")
        wait_for(lambda: link.pump() != (0, 0) or not link.is_open)
        assert not link.is_open and link.pump() == (0, 0)
    finally:
        os.close(host)
        link.close()
