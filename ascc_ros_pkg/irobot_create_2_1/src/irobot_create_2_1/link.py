"""A serial port that survives being unplugged: opened lazily, closed on any I/O error and
reopened with exponential back-off. No ROS; the clock is injectable for tests."""
import time
from typing import Callable, Optional

import serial


class SerialLink:
    def __init__(self, port: str, baud: int = 57600, read_timeout_s: float = 0.02,
                 backoff_initial_s: float = 0.25, backoff_max_s: float = 4.0,
                 clock: Callable[[], float] = time.monotonic,
                 open_fn: Callable[..., serial.Serial] = serial.Serial):
        self.port = port
        self.baud = baud
        self.read_timeout_s = read_timeout_s
        self.backoff_initial_s = backoff_initial_s
        self.backoff_max_s = backoff_max_s
        self._clock = clock
        self._open_fn = open_fn
        self._ser: Optional[serial.Serial] = None
        self._backoff_s = backoff_initial_s
        self._next_attempt = 0.0
        self.opens = 0          # successful opens (1 + reconnects)
        self.failures = 0       # failed opens and I/O errors
        self.last_error = ""

    @property
    def is_open(self) -> bool:
        return self._ser is not None

    def ensure_open(self) -> bool:
        """Open the port unless open; respects the back-off. True when open."""
        if self._ser is not None:
            return True
        now = self._clock()
        if now < self._next_attempt:
            return False
        try:
            self._ser = self._open_fn(self.port, self.baud, timeout=self.read_timeout_s,
                                      write_timeout=0.5)
        except (serial.SerialException, OSError, ValueError) as exc:
            self._fail("cannot open %s: %s" % (self.port, exc))
            return False
        self.opens += 1
        self._backoff_s = self.backoff_initial_s
        self.last_error = ""
        return True

    def read(self, max_bytes: int = 4096, min_bytes: int = 1) -> bytes:
        """Bytes available; waits up to the read timeout for ``min_bytes`` of them (returns
        fewer when it expires, b'' when nothing came or the port is closed)."""
        if self._ser is None:
            return b""
        try:
            first = self._ser.read(max(1, min(min_bytes, max_bytes)))
            if not first:
                return b""
            waiting = self._ser.in_waiting
            more = min(waiting, max_bytes - len(first))
            return first + (self._ser.read(more) if more > 0 else b"")
        except (serial.SerialException, OSError, TypeError) as exc:
            # pyserial raises TypeError from inside read() when the fd vanished
            self._fail("read from %s failed: %s" % (self.port, exc))
            return b""

    def write(self, data: bytes) -> bool:
        if self._ser is None:
            return False
        try:
            self._ser.write(data)
            return True
        except (serial.SerialException, OSError, TypeError) as exc:
            # TypeError: pyserial's write when the port is closed under it (at shutdown)
            self._fail("write to %s failed: %s" % (self.port, exc))
            return False

    def close(self) -> None:
        if self._ser is not None:
            try:
                self._ser.close()
            except (serial.SerialException, OSError):
                pass  # already gone: closing is best effort
            self._ser = None

    def _fail(self, message: str) -> None:
        self.close()
        self.failures += 1
        self.last_error = message
        self._next_attempt = self._clock() + self._backoff_s
        self._backoff_s = min(self._backoff_s * 2.0, self.backoff_max_s)
