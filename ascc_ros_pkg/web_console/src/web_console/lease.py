"""The drive lease (no rospy): one console drives at a time, for ``lease_s`` after its
last command.

A command is only good for ``lease_s`` (about 0.2 s): the page repeats it while the
joystick is held (every 50 ms). When the page stops sending (the tab closed, the network
cut, the joystick let go) the lease runs out and the server sends one zero command, so the
robot stops within ``lease_s`` plus the check period, whatever the mux's own timeout is.
The caller passes the time (``time.monotonic()``) so tests need no clock.
"""
from __future__ import annotations

from typing import Hashable, Optional

HOLD, BUSY, STOP = "hold", "busy", "stop"


class DriveLease:
    """Who drives and until when; ``tick`` says when a zero command is due."""

    def __init__(self, lease_s: float):
        if not lease_s > 0.0:
            raise ValueError("lease_s must be > 0 s, not %r" % (lease_s,))
        self.lease_s = lease_s
        self.holder: Optional[Hashable] = None
        self.expires = 0.0

    def command(self, client: Hashable, now: float) -> str:
        """A drive command from ``client`` at ``now``: HOLD (publish it; the lease is
        renewed) or BUSY (another console holds a live lease: refuse)."""
        if self.holder is not None and self.holder != client and now < self.expires:
            return BUSY
        self.holder = client
        self.expires = now + self.lease_s
        return HOLD

    def release(self, client: Hashable) -> bool:
        """``client`` lets go (joystick released, page closed); True when it held the lease:
        a zero command is due at once."""
        if self.holder is not None and self.holder == client:
            self.holder = None
            return True
        return False

    def tick(self, now: float) -> bool:
        """True once when the holder's lease has run out (send one zero command)."""
        if self.holder is not None and now >= self.expires:
            self.holder = None
            return True
        return False

    def reset(self) -> bool:
        """Forget the holder (e-stop); True when one held it."""
        held = self.holder is not None
        self.holder = None
        return held
