"""The Q24 driver's pure parts (target_follower.camera_driver): parameters, back-off, the
newest-frame slot, the rate meter, the warning throttle and the JPEG check."""
import os
import sys
import threading

import pytest

from ascc_common.params import ParamError, from_params
from ascc_common.throttle import Throttle
from target_follower.camera_driver import (
    Backoff,
    NewestFrame,
    Q24CameraParams,
    RateMeter,
    jpeg_problem,
)
from target_follower.mjpeg import Frame

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from fake_q24 import corrupt, make_jpeg, numbered  # noqa: E402  (helper next to this file)


class Clock:
    def __init__(self):
        self.t = 100.0

    def __call__(self):
        return self.t


def frame(i):
    return Frame(b"%d" % i, float(i), float(i), {})


def test_params_need_a_url_and_ordered_backoff():
    with pytest.raises(ParamError, match="url"):
        from_params(Q24CameraParams, {}.get, "~")
    p = from_params(Q24CameraParams, {"~url": "http://cam/x"}.get, "~")
    assert (p.frame_id, p.publish_raw) == ("camera", False)
    with pytest.raises(ParamError, match="reconnect_max_s"):
        from_params(Q24CameraParams, {"~url": "http://cam/x", "~reconnect_min_s": 5.0,
                                      "~reconnect_max_s": 1.0}.get, "~")


def test_backoff_doubles_to_the_cap_and_resets():
    b = Backoff(0.5, 3.0)
    assert [b.next_delay() for _ in range(5)] == [0.5, 1.0, 2.0, 3.0, 3.0]
    b.reset()
    assert b.next_delay() == 0.5


def test_newest_frame_slot_never_queues_and_counts_drops():
    slot = NewestFrame()
    for i in range(5):
        slot.put(frame(i))
    assert slot.take(0.0).data == b"4"
    assert (slot.received, slot.dropped) == (5, 4)
    assert slot.take(0.0) is None
    slot.put(frame(5))
    assert slot.take(0.0).data == b"5"
    assert slot.dropped == 4  # taken in time: not a drop


def test_newest_frame_take_wakes_on_put_and_close():
    slot = NewestFrame()
    got = []
    thread = threading.Thread(target=lambda: got.append(slot.take(10.0)))
    thread.start()
    slot.put(frame(7))
    thread.join(5.0)
    assert got[0].data == b"7"
    thread = threading.Thread(target=lambda: got.append(slot.take(10.0)))
    thread.start()
    slot.close()
    thread.join(5.0)
    assert not thread.is_alive() and got[1] is None


def test_rate_meter_over_its_window():
    clock = Clock()
    meter = RateMeter(window_s=2.0, clock=clock)
    assert meter.rate_hz() == 0.0
    for _ in range(21):
        meter.tick()
        clock.t += 0.1
    clock.t -= 0.1
    assert meter.rate_hz() == pytest.approx(10.0)
    clock.t += 5.0  # nothing for longer than the window
    assert meter.rate_hz() == 0.0


def test_warn_throttle_per_kind():
    """The driver's warnings go through ascc_common's Throttle on the monotonic clock."""
    clock = Clock()
    throttle = Throttle(5.0)
    assert throttle.ready("corrupt", clock())
    assert not throttle.ready("corrupt", clock())
    assert throttle.ready("HttpStatusError", clock())  # another kind is not hidden
    clock.t += 5.0
    assert throttle.ready("corrupt", clock())
    clock.t -= 50.0  # time went back
    assert throttle.ready("corrupt", clock())


def test_jpeg_problem_accepts_good_and_names_each_corruption():
    good = numbered(make_jpeg(160, 120), 3)
    assert jpeg_problem(good) == (None, None)
    problem, image = jpeg_problem(good, full=True)
    assert problem is None and image.shape == (120, 160, 3)
    assert jpeg_problem(good + b"\r\n")[0] is None  # padding after EOI is tolerated
    assert "SOI" in jpeg_problem(corrupt(good, 0))[0]
    assert "EOI" in jpeg_problem(corrupt(good, 1))[0]
    assert "does not decode" in jpeg_problem(corrupt(good, 2))[0]
    # without decoding only the markers are checked
    assert jpeg_problem(corrupt(good, 2), decode=False) == (None, None)
    assert "SOI" in jpeg_problem(b"")[0]
