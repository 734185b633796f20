"""The drive lease: one page drives; its commands hold for lease_s; one zero when it ends."""
import pytest

from web_console.lease import BUSY, HOLD, DriveLease


def test_commands_renew_and_expiry_gives_one_zero():
    lease = DriveLease(0.2)
    assert lease.command("a", 10.0) == HOLD
    assert not lease.tick(10.15)
    assert lease.command("a", 10.15) == HOLD  # renewed: now until 10.35
    assert not lease.tick(10.3)
    assert lease.tick(10.35)  # ran out: one zero
    assert not lease.tick(10.4)  # ... only one
    assert lease.holder is None


def test_another_page_waits_until_the_lease_ends():
    lease = DriveLease(0.2)
    assert lease.command("a", 0.0) == HOLD
    assert lease.command("b", 0.1) == BUSY
    assert lease.holder == "a"
    assert lease.command("b", 0.21) == HOLD  # a's lease is over
    assert lease.holder == "b"


def test_release_by_holder_only():
    lease = DriveLease(0.2)
    lease.command("a", 0.0)
    assert not lease.release("b")
    assert lease.holder == "a"
    assert lease.release("a")  # zero due now
    assert not lease.release("a")
    assert not lease.tick(1.0)  # nothing more to stop
    assert lease.command("b", 0.05) == HOLD


def test_reset_and_bad_lease():
    lease = DriveLease(0.2)
    assert not lease.reset()
    lease.command("a", 0.0)
    assert lease.reset() and lease.holder is None
    with pytest.raises(ValueError):
        DriveLease(0.0)
