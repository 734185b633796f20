"""Serve a byte-level robot emulator (e.g. VirtualCreate) on a pseudo-terminal.

The host (the real driver, pyserial, minicom) opens ``PtyLink.port`` like a USB-serial
adapter. Nothing here blocks: ``pump()`` moves whatever bytes are available in each
direction and returns; when the host does not read and the kernel's pty buffer is full,
robot->host bytes are dropped (and counted), as a UART drops them.

The slave side is put in raw mode (no echo, no CR/LF translation, no signals): without it
the line discipline would echo the host's commands back as "sensor data" and turn 0x0D
into 0x0A. Our own slave descriptor stays open for the link's lifetime, so the master never
sees EIO while no host has the port open. ``pump``, ``inject``, ``close`` and ``reopen``
hold one lock: a close from another thread (a shutdown hook) waits for a pump in progress
instead of pulling the descriptor from under it; a close from a signal handler in the
pumping thread itself (rospy's shutdown on SIGINT) ends that pump cleanly.
"""

from __future__ import annotations

import errno
import fcntl
import os
import threading
import tty
from typing import Optional, Tuple

READ_CHUNK_BYTES = 4096


class PtyLink:
    """A pseudo-terminal in front of ``create`` (anything with feed(bytes)/read_output())."""

    def __init__(self, create, link_path: Optional[str] = None):
        self.create = create
        self.link_path = link_path
        self.tty_path = ""          # the /dev/pts/N of the current pty ('' when closed)
        self._master: Optional[int] = None
        self._slave: Optional[int] = None
        self.bytes_in = 0           # host -> robot bytes delivered
        self.bytes_out = 0          # robot -> host bytes written
        self.dropped_bytes = 0      # robot -> host bytes lost (buffer full or link closed)
        self.opens = 0
        self._lock = threading.RLock()
        self._open()

    # ------------------------------------------------------------------ public
    @property
    def port(self) -> str:
        """Path for the host to open: the symlink if one was asked for, else /dev/pts/N."""
        return self.link_path if self.link_path else self.tty_path

    @property
    def is_open(self) -> bool:
        return self._master is not None

    def fileno(self) -> int:
        """Master descriptor (for select/poll); ValueError when closed."""
        if self._master is None:
            raise ValueError("pty link is closed")
        return self._master

    def pump(self) -> Tuple[int, int]:
        """Move host->robot bytes into create.feed and create.read_output() to the host.

        Never blocks. Returns (bytes_in, bytes_out) moved by this call. While the link is
        closed the robot's output is drained and dropped (nobody is on the wire).
        """
        with self._lock:
            if self._master is None:
                lost = len(self.create.read_output())
                self.dropped_bytes += lost
                return 0, 0
            n_in = 0
            while True:
                data = self._read_master()
                if not data:
                    break
                n_in += len(data)
                self.create.feed(data)
            self.bytes_in += n_in
            n_out = self._write_master(self.create.read_output())
            return n_in, n_out

    def inject(self, data: bytes) -> int:
        """Write raw robot->host bytes (e.g. garbage for tests); returns bytes written."""
        with self._lock:
            if self._master is None:
                self.dropped_bytes += len(data)
                return 0
            return self._write_master(bytes(data))

    def close(self) -> None:
        """Close the pty (the host sees a hang-up) and remove our symlink."""
        with self._lock:
            if self._master is None:
                return
            self._remove_link()
            for fd in (self._master, self._slave):
                try:
                    os.close(fd)
                except OSError:
                    pass                               # already gone: closing is best effort
            self._master = self._slave = None
            self.tty_path = ""

    def reopen(self) -> None:
        """A new pty behind the same symlink: a USB-serial adapter unplugged and replugged."""
        with self._lock:
            self.close()
            self._open()

    def __enter__(self) -> PtyLink:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    # ------------------------------------------------------------------ internals
    def _open(self) -> None:
        master, slave = os.openpty()
        try:
            tty.setraw(slave)
            flags = fcntl.fcntl(master, fcntl.F_GETFL)
            fcntl.fcntl(master, fcntl.F_SETFL, flags | os.O_NONBLOCK)
            tty_path = os.ttyname(slave)
            if self.link_path:
                self._make_link(tty_path)
        except BaseException:
            os.close(master)
            os.close(slave)
            raise
        self._master, self._slave, self.tty_path = master, slave, tty_path
        self.opens += 1

    def _make_link(self, target: str) -> None:
        path = self.link_path
        if os.path.lexists(path) and not os.path.islink(path):
            raise FileExistsError("%s exists and is not a symlink; refusing to replace it"
                                  % path)
        tmp = "%s.tmp%d" % (path, os.getpid())
        if os.path.lexists(tmp):
            os.unlink(tmp)
        os.symlink(target, tmp)
        os.replace(tmp, path)                          # atomic: replaces a stale link

    def _remove_link(self) -> None:
        path = self.link_path
        if path and os.path.islink(path) and os.readlink(path) == self.tty_path:
            os.unlink(path)

    def _read_master(self) -> bytes:
        if self._master is None:  # closed by a signal handler inside pump (the lock is
            return b""            # re-entrant, so the same thread's close gets through)
        try:
            return os.read(self._master, READ_CHUNK_BYTES)
        except BlockingIOError:
            return b""
        except OSError as exc:
            if exc.errno == errno.EIO:                 # no slave side open (cannot happen
                return b""                             # while we hold ours, but be safe)
            raise

    def _write_master(self, data: bytes) -> int:
        written = 0
        while written < len(data) and self._master is not None:
            try:
                n = os.write(self._master, data[written:])
            except BlockingIOError:
                break
            except OSError as exc:
                if exc.errno == errno.EIO:
                    break
                raise
            if n <= 0:
                break
            written += n
        self.bytes_out += written
        self.dropped_bytes += len(data) - written
        return written
