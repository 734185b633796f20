"""Throttle: one warning per period per kind; time going back restarts it."""
from ascc_common.throttle import Throttle


def test_throttle_is_per_kind():
    t = Throttle(5.0)
    assert t.ready("saturated", 0.0)
    assert not t.ready("saturated", 1.0)
    assert t.ready("rejected", 1.0)          # a frequent kind does not hide another
    assert not t.ready("rejected", 5.9)
    assert not t.ready("saturated", 4.99)
    assert t.ready("saturated", 5.0)
    assert t.ready("rejected", 6.0)
    assert t.ready("rejected", 2.0)          # time went back (restarted simulator)
