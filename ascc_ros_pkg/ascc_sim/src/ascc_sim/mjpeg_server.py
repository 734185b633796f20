"""An MJPEG-over-HTTP server on loopback, the way a Mobotix camera streams (no rospy).

``GET <path>`` answers ``HTTP/1.0 200`` with ``Content-Type: multipart/x-mixed-replace;
boundary=<b>`` and then, for every new frame, ``--<b>\\r\\nContent-Type: image/jpeg\\r\\n
Content-Length: N\\r\\n\\r\\n<N bytes>\\r\\n`` (the Q24's ``faststream`` style); any other
path answers 404. The newest frame wins: there is no queue; each client's thread sends
the newest frame it has not sent yet, so a slow client skips frames instead of lagging
behind. A client that disconnects ends its own thread only.

Standard library only (``http.server.ThreadingHTTPServer``)::

    server = MjpegServer(port=0)      # 0: any free port
    port = server.start()             # serving in a background thread
    server.publish(jpeg_bytes)        # from the producer, any thread
    server.stop()
"""
from __future__ import annotations

import threading
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from typing import Optional


class MjpegServer:
    """Serves the newest published JPEG frame to every client of ``path``."""

    def __init__(self, host: str = "127.0.0.1", port: int = 0, path: str = "/",
                 boundary: str = "ascc_sim_frame"):
        self.host = host
        self.path = path
        self.boundary = boundary
        self._requested_port = int(port)
        self._cond = threading.Condition()
        self._frame: Optional[bytes] = None
        self._seq = 0  # number of frames published
        self._stopped = False
        self._httpd: Optional[ThreadingHTTPServer] = None
        self._thread: Optional[threading.Thread] = None

    @property
    def port(self) -> int:
        """The bound port (after ``start()``), else the requested one."""
        return self._httpd.server_address[1] if self._httpd else self._requested_port

    def start(self) -> int:
        """Bind and serve in a daemon thread; returns the bound port."""
        handler = _make_handler(self)
        self._httpd = ThreadingHTTPServer((self.host, self._requested_port), handler)
        self._httpd.daemon_threads = True
        self._thread = threading.Thread(target=self._httpd.serve_forever,
                                        name="mjpeg_server", daemon=True)
        self._thread.start()
        return self.port

    def publish(self, jpeg: bytes) -> None:
        """Make ``jpeg`` the newest frame (the previous one is dropped if not yet sent)."""
        with self._cond:
            self._frame = bytes(jpeg)
            self._seq += 1
            self._cond.notify_all()

    def stop(self) -> None:
        """Stop serving and end the client threads."""
        with self._cond:
            self._stopped = True
            self._cond.notify_all()
        if self._httpd is not None:
            self._httpd.shutdown()
            self._httpd.server_close()
        if self._thread is not None:
            self._thread.join(timeout=5.0)

    def wait_frame(self, after_seq: int, timeout_s: float):
        """(seq, frame) of the newest frame newer than ``after_seq``, or (after_seq,
        None) on timeout or stop."""
        with self._cond:
            self._cond.wait_for(lambda: self._stopped or self._seq > after_seq, timeout_s)
            if self._stopped or self._seq <= after_seq:
                return after_seq, None
            return self._seq, self._frame

    @property
    def stopped(self) -> bool:
        return self._stopped


def _make_handler(server: MjpegServer):
    class Handler(BaseHTTPRequestHandler):
        protocol_version = "HTTP/1.0"
        server_version = "ascc_sim_mjpeg/1.0"

        def do_GET(self):  # noqa: N802 (http.server's name)
            if self.path.split("?", 1)[0] != server.path:
                self.send_error(404, "not found (the stream is at %s)" % server.path)
                return
            self.send_response(200)
            self.send_header("Content-Type", "multipart/x-mixed-replace; boundary=%s"
                             % server.boundary)
            self.send_header("Cache-Control", "no-cache")
            self.end_headers()
            seq = 0
            try:
                while not server.stopped:
                    seq, frame = server.wait_frame(seq, 0.5)
                    if frame is None:
                        continue
                    self.wfile.write(b"--%s\r\nContent-Type: image/jpeg\r\n"
                                     b"Content-Length: %d\r\n\r\n"
                                     % (server.boundary.encode("ascii"), len(frame)))
                    self.wfile.write(frame)
                    self.wfile.write(b"\r\n")
                    self.wfile.flush()
            except (BrokenPipeError, ConnectionResetError, ConnectionAbortedError):
                return  # the client went away: end this thread only

        def log_message(self, format, *args):  # noqa: A002 (http.server's signature)
            pass  # no per-request lines on stderr

    return Handler
