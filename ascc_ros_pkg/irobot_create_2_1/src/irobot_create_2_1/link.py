"""A serial port that survives being unplugged: opened lazily, closed on any I/O error and
reopened with exponential back-off. No ROS; the clock is injectable for tests."""
import time
from typing import Callable, Optional

import serial

PACE_MARGIN_S = 0.001  # read_paced sleeps this much past the bytes' expected arrival


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
        self._paced_rate = 0.0  # bytes/s seen by read_paced over the last reads
        self._paced_end: Optional[float] = None  # when the last read_paced with bytes ended

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
        ser = self._ser  # another thread may close the link (and clear _ser) meanwhile
        if ser is None:
            return b""
        try:
            first = ser.read(max(1, min(min_bytes, max_bytes)))
            if not first:
                return b""
            waiting = ser.in_waiting
            more = min(waiting, max_bytes - len(first))
            return first + (ser.read(more) if more > 0 else b"")
        except (serial.SerialException, OSError, TypeError) as exc:
            # pyserial raises TypeError from inside read() when the fd vanished
            self._fail("read from %s failed: %s" % (self.port, exc))
            return b""

    def read_paced(self, min_bytes: int, rate_bytes_s: float, max_bytes: int = 4096,
                   sleep: Callable[[float], None] = time.sleep) -> bytes:
        """Like :meth:`read`, for a stream of known rate: instead of waking on every chunk
        the kernel hands over (a frame, or a USB packet), it sleeps for the time the missing
        bytes take (plus 1 ms) and looks again, until ``min_bytes`` wait or the read
        timeout passed; then it returns all that waits (up to ``max_bytes``; b'' when
        nothing came or the port is closed). One wake-up per ``min_bytes`` of a steady
        stream instead of one per chunk. The rate is ``rate_bytes_s`` [bytes/s, wall
        time], or the rate the bytes came at over the last reads when that is higher (a
        simulated robot faster than real time sends its stream faster). When nothing came
        by the timeout, it ends with :meth:`read` (one more read timeout), which also finds
        a device that hung up (it reads as ready with no data)."""
        ser = self._ser  # closed by another thread meanwhile: pyserial raises, caught below
        if ser is None:
            return b""
        deadline = self._clock() + self.read_timeout_s
        rate = max(rate_bytes_s, self._paced_rate)
        try:
            while True:
                waiting = ser.in_waiting
                left = deadline - self._clock()
                if waiting >= min_bytes or left <= 0.0:
                    break
                sleep(min(left, (min_bytes - waiting) / rate + PACE_MARGIN_S))
            data = ser.read(min(waiting, max_bytes)) if waiting > 0 else \
                self.read(max_bytes, 1)
        except (serial.SerialException, OSError, TypeError) as exc:
            self._fail("read from %s failed: %s" % (self.port, exc))
            return b""
        end = self._clock()
        if self._paced_end is not None and end > self._paced_end and data:
            seen = len(data) / (end - self._paced_end)
            self._paced_rate = 0.5 * (self._paced_rate + seen) if self._paced_rate else seen
        self._paced_end = end if data else None
        return data

    def write(self, data: bytes) -> bool:
        ser = self._ser
        if ser is None:
            return False
        try:
            ser.write(data)
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
