"""SerialLink against a real pseudo-terminal: open, read, write, loss and reopen."""
import contextlib
import os
import time
import tty

from irobot_create_2_1.link import PACE_MARGIN_S, SerialLink


class FakeClock:
    def __init__(self):
        self.t = 0.0

    def __call__(self):
        return self.t


def make_pty():
    master, slave = os.openpty()
    tty.setraw(slave)
    return master, slave, os.ttyname(slave)


@contextlib.contextmanager
def open_link(**kwargs):
    """(master fd, open SerialLink on the slave) of a new pty; everything closed after."""
    master, slave, path = make_pty()
    link = SerialLink(path, **kwargs)
    try:
        assert link.ensure_open()
        yield master, link
    finally:
        link.close()
        os.close(master)
        os.close(slave)


def send(master, link, data):
    """Write ``data`` on the pty's master and wait until the link sees it waiting (the
    kernel hands pty bytes over in a worker; a fixed sleep would test the scheduler).
    Guard: 10 s."""
    before = link._ser.in_waiting
    os.write(master, data)
    for _ in range(10000):
        if link._ser.in_waiting >= before + len(data):
            return
        time.sleep(0.001)
    raise AssertionError("%d bytes written to the pty never arrived" % len(data))


def test_read_write_through_pty():
    with open_link(read_timeout_s=0.2) as (master, link):
        assert link.write(b"\x80\x83")
        assert os.read(master, 16) == b"\x80\x83"
        os.write(master, b"hello")
        got = b""
        for _ in range(10):
            got += link.read()
            if len(got) >= 5:
                break
        assert got == b"hello"


def test_missing_port_backs_off_and_recovers(tmp_path):
    clock = FakeClock()
    link_path = str(tmp_path / "create")
    link = SerialLink(link_path, clock=clock, backoff_initial_s=0.5, backoff_max_s=2.0)
    assert not link.ensure_open()
    assert link.failures == 1 and "cannot open" in link.last_error
    clock.t = 0.1
    assert not link.ensure_open()
    assert link.failures == 1  # inside the back-off: no attempt
    clock.t = 0.6
    assert not link.ensure_open()
    assert link.failures == 2  # next back-off is 1.0 s
    master, slave, path = make_pty()
    try:
        os.symlink(path, link_path)
        clock.t = 1.0
        assert not link.ensure_open()  # still backing off
        clock.t = 1.7
        assert link.ensure_open()
        assert link.opens == 1
    finally:
        link.close()
        os.close(master)
        os.close(slave)


def test_closed_master_is_detected():
    master, slave, path = make_pty()
    link = SerialLink(path, read_timeout_s=0.05)
    assert link.ensure_open()
    os.close(master)
    os.close(slave)
    for _ in range(20):
        link.read()
        link.write(b"\x00")
        if not link.is_open:
            break
    assert not link.is_open
    assert link.failures >= 1


def test_a_port_closed_under_a_write_is_a_failure_not_a_crash():
    """pyserial raises TypeError from write() when the port is closed in another thread
    (seen at shutdown: the driver's last zero command after the simulator's pty went);
    the race is not reproducible, so the serial object's write raises it here."""
    with open_link(read_timeout_s=0.05) as (master, link):
        def closed_under_us(_data):
            raise TypeError("'NoneType' object cannot be interpreted as an integer")

        link._ser.write = closed_under_us
        assert link.write(b"\x89") is False
        assert not link.is_open and link.failures >= 1


def test_read_waits_for_min_bytes_within_the_timeout():
    with open_link(read_timeout_s=0.5) as (master, link):
        os.write(master, b"abc")
        got = [link.read(min_bytes=6)]
        os.write(master, b"def")              # arrives after the first read timed out
        got.append(link.read(min_bytes=3))
        assert got == [b"abc", b"def"]        # the timeout returns what came
        os.write(master, b"0123456789")
        assert link.read(max_bytes=4, min_bytes=8) == b"0123"  # never more than max


def test_read_paced_sleeps_for_the_missing_bytes_and_returns_all_that_waits():
    """A stream at 1000 bytes/s: asking for 8 bytes with 3 waiting sleeps 5 ms (+ the
    margin), once, and returns everything buffered by then, not only 8 bytes."""
    with open_link(read_timeout_s=0.5) as (master, link):
        send(master, link, b"abc")
        naps = []

        def sleep(s):
            naps.append(s)
            send(master, link, b"defghijk" if len(naps) == 1 else b"")

        assert link.read_paced(8, 1000.0, sleep=sleep) == b"abcdefghijk"
        assert len(naps) == 1 and abs(naps[0] - (0.005 + PACE_MARGIN_S)) < 1e-9
        send(master, link, b"0123456789")
        assert link.read_paced(4, 1000.0, max_bytes=6, sleep=sleep) == b"012345"
        assert len(naps) == 1  # enough was waiting: no sleep


def test_read_paced_returns_what_came_within_the_timeout():
    with open_link(read_timeout_s=0.05) as (master, link):
        send(master, link, b"ab")
        t0 = time.monotonic()
        assert link.read_paced(10, 1e4) == b"ab"  # never comes: the timeout ends it
        # it waited out the read timeout (0.05 s), and then ended (the upper bound only
        # tells an end from a hang: a loaded machine may delay the return)
        assert 0.04 < time.monotonic() - t0 < 10.0
        assert link.read_paced(10, 1e4) == b""  # nothing at all: b'' after read()
        assert link.is_open


def test_read_paced_finds_a_device_that_hung_up():
    master, slave, path = make_pty()
    link = SerialLink(path, read_timeout_s=0.05)
    assert link.ensure_open()
    os.close(master)
    os.close(slave)
    for _ in range(5):
        link.read_paced(10, 1e4)
        if not link.is_open:
            break
    assert not link.is_open and link.failures >= 1


def test_read_paced_survives_the_link_closed_by_another_thread():
    """The driver's shutdown hook (or a service's failed write) closes the link while the
    reader thread sleeps in read_paced: the read ends with b'' and a recorded failure,
    not an AttributeError that kills the reader thread."""
    with open_link(read_timeout_s=0.5) as (master, link):
        send(master, link, b"ab")

        def sleep(_s):
            link.close()  # as another thread would, between two looks at the port

        assert link.read_paced(10, 1000.0, sleep=sleep) == b""
        assert not link.is_open and link.failures == 1 and "read from" in link.last_error
        assert link.read_paced(10, 1000.0, sleep=sleep) == b""  # closed: nothing, no error
        assert link.failures == 1


def test_read_paced_follows_a_stream_faster_than_its_nominal_rate():
    """A simulated robot at 4x real time sends 4000 bytes/s where 1000 are nominal: after
    two reads the pacing sleeps a quarter as long (it would otherwise hold back the
    watchdog and the commands, which run once per read)."""
    clock = FakeClock()
    with open_link(read_timeout_s=0.5, clock=clock) as (master, link):
        naps = []

        def sleep(s):
            naps.append(s)
            clock.t += s
            send(master, link, b"x" * int(round(4000 * s)))

        got = [len(link.read_paced(40, 1000.0, sleep=sleep)) for _ in range(3)]
        assert got[0] == got[1] == 164  # 41 ms of the stream each
        assert abs(naps[0] - 0.041) < 1e-9 and abs(naps[1] - 0.041) < 1e-9
        assert abs(naps[2] - (40 / 4000.0 + PACE_MARGIN_S)) < 1e-9
