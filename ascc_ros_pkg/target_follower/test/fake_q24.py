#!/usr/bin/env python3
"""A fake Mobotix Q24 for the driver's tests: an MJPEG (multipart/x-mixed-replace) HTTP
server on loopback that can also misbehave, over real sockets.

``FakeQ24(...).start()`` serves ``path`` (default ``/stream``); every other path answers
404 and ``/page.html`` answers an HTML page with status 200 (what a camera's login page
looks like to a client). Each frame sent is a JPEG made unique by a comment segment
carrying its number (so a test can match what it received with what was sent: see
``sent``). Behaviour, changeable while it runs:

* ``boundary`` / ``header_boundary`` (how the Content-Type names it: e.g. quoted or with a
  leading ``--``) / ``body_dashes`` (delimiter lines ``--B`` or ``B``);
* ``content_length`` (per-part Content-Length or not); ``fps``;
* ``stall_after`` (N: after N frames of a connection send nothing more, keep it open);
  ``stalled`` (all connections stop sending until cleared);
* ``cut_after`` (N: after N frames send half of the next part and close);
  ``cut_now()`` (every open connection does so at its next frame);
* ``garbage_every`` (K: every K-th frame is replaced by a corrupt one, in turn: no SOI,
  no EOI (truncated), SOI + noise + EOI); ``answer`` ("stream", "404", "html": what the
  stream path answers to new connections).

Run as a script (``fake_q24.py --port 8080``) it serves until interrupted.
"""
import argparse
import http.server
import socketserver
import threading
import time
from typing import List, NamedTuple, Optional

import cv2
import numpy as np


class Sent(NamedTuple):
    index: int
    data: bytes           # the JPEG bytes as sent (corrupt ones included)
    wall_s: float         # time.time() just before the part's first byte was written
    corrupt: bool


def make_jpeg(width=320, height=240, seed=0, quality=80):
    """A textured test image as JPEG bytes (not uniform, so decoding does real work)."""
    rng = np.random.default_rng(seed)
    y, x = np.mgrid[0:height, 0:width]
    img = np.stack([(x * 255 // max(width - 1, 1)), (y * 255 // max(height - 1, 1)),
                    ((x + y) % 64) * 4], axis=-1).astype(np.uint8)
    img = cv2.GaussianBlur(img, (3, 3), 0)
    img[rng.random((height, width)) < 0.01] = 255
    ok, buf = cv2.imencode(".jpg", img, [cv2.IMWRITE_JPEG_QUALITY, quality])
    assert ok
    return buf.tobytes()


def numbered(jpeg, index):
    """``jpeg`` with a COM segment after SOI holding ``index``: still a valid JPEG."""
    text = b"fake_q24 frame %d" % index
    return jpeg[:2] + b"\xff\xfe" + (len(text) + 2).to_bytes(2, "big") + text + jpeg[2:]


def corrupt(jpeg, index):
    """A corrupt frame of one of three kinds, chosen by ``index``."""
    kind = index % 3
    if kind == 0:
        return bytes(np.random.default_rng(index).integers(0, 256, 2000, dtype=np.uint8))
    if kind == 1:
        return jpeg[: len(jpeg) // 2]  # truncated: no EOI
    noise = bytes(np.random.default_rng(index).integers(0, 256, len(jpeg) - 4,
                                                        dtype=np.uint8))
    return b"\xff\xd8" + noise.replace(b"\xff", b"\x00") + b"\xff\xd9"


class _Server(socketserver.ThreadingMixIn, http.server.HTTPServer):
    daemon_threads = True
    allow_reuse_address = True


class FakeQ24:
    def __init__(self, host="127.0.0.1", port=0, path="/stream", boundary="q24frame",
                 header_boundary=None, body_dashes=True, content_length=True, fps=15.0,
                 jpeg=None):
        self.host, self.port, self.path = host, port, path
        self.boundary = boundary
        self.header_boundary = header_boundary  # None: the boundary as it is
        self.body_dashes = body_dashes
        self.content_length = content_length
        self.fps = fps
        self.jpeg = jpeg if jpeg is not None else make_jpeg()
        self.answer = "stream"
        self.stall_after: Optional[int] = None
        self.cut_after: Optional[int] = None
        self.garbage_every: Optional[int] = None
        self.stalled = threading.Event()
        self.sent: List[Sent] = []
        self.connections = 0
        self._cut_generation = 0
        self._lock = threading.Lock()
        self._index = 0
        self._stop = threading.Event()
        self._server = None
        self._thread = None

    @property
    def url(self):
        return "http://%s:%d%s" % (self.host, self.port, self.path)

    def start(self):
        fake = self

        class Handler(http.server.BaseHTTPRequestHandler):
            protocol_version = "HTTP/1.0"

            def log_message(self, *args):  # quiet
                pass

            def do_GET(self):
                fake._serve(self)

        self._server = _Server((self.host, self.port), Handler)
        self.port = self._server.server_address[1]
        self._thread = threading.Thread(target=self._server.serve_forever, daemon=True,
                                        kwargs={"poll_interval": 0.05})
        self._thread.start()
        return self.port

    def stop(self):
        self._stop.set()
        if self._server is not None:
            self._server.shutdown()
            self._server.server_close()

    def cut_now(self):
        """Every open connection sends half of its next part, then closes."""
        with self._lock:
            self._cut_generation += 1

    def sent_frames(self, good_only=True):
        with self._lock:
            return [s for s in self.sent if not (good_only and s.corrupt)]

    # --- serving ------------------------------------------------------------------------
    def _serve(self, handler):
        path = handler.path.split("?", 1)[0]
        with self._lock:
            self.connections += 1
            answer = self.answer
        if path == "/page.html" or (path == self.path and answer == "html"):
            body = b"<html><body><h1>MOBOTIX Q24</h1>Please log in.</body></html>\n"
            handler.send_response(200)
            handler.send_header("Content-Type", "text/html")
            handler.send_header("Content-Length", str(len(body)))
            handler.end_headers()
            handler.wfile.write(body)
            return
        if path != self.path or answer == "404":
            handler.send_error(404, "Not Found")
            return
        shown = self.header_boundary if self.header_boundary is not None else self.boundary
        handler.send_response(200)
        handler.send_header("Content-Type", "multipart/x-mixed-replace; boundary=%s" % shown)
        handler.send_header("Cache-Control", "no-cache")
        handler.end_headers()
        delimiter = ("--" if self.body_dashes else "") + self.boundary
        with self._lock:
            generation = self._cut_generation
        count = 0
        try:
            while not self._stop.is_set():
                if self.stalled.is_set() or (self.stall_after is not None
                                             and count >= self.stall_after):
                    time.sleep(0.02)
                    continue
                with self._lock:
                    index = self._index
                    self._index += 1
                    cut = (self._cut_generation != generation
                           or (self.cut_after is not None and count >= self.cut_after))
                bad = bool(self.garbage_every) and index % self.garbage_every == 0
                data = numbered(self.jpeg, index)
                if bad:
                    data = corrupt(data, index)
                head = ("%s\r\nContent-Type: image/jpeg\r\n" % delimiter).encode()
                if self.content_length:
                    head += b"Content-Length: %d\r\n" % len(data)
                part = head + b"\r\n" + data + b"\r\n"
                if cut:
                    handler.wfile.write(part[: len(head) + len(data) // 2])
                    handler.wfile.flush()
                    return
                with self._lock:
                    self.sent.append(Sent(index, data, time.time(), bad))
                handler.wfile.write(part)
                handler.wfile.flush()
                count += 1
                self._stop.wait(1.0 / self.fps)
        except (BrokenPipeError, ConnectionResetError):
            return  # the client went away


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--port", type=int, default=8080)
    parser.add_argument("--fps", type=float, default=15.0)
    parser.add_argument("--no-content-length", action="store_true")
    parser.add_argument("--garbage-every", type=int, default=0)
    args = parser.parse_args()
    fake = FakeQ24(port=args.port, fps=args.fps,
                   content_length=not args.no_content_length)
    fake.garbage_every = args.garbage_every or None
    fake.start()
    print("serving %s" % fake.url, flush=True)
    try:
        while True:
            time.sleep(1.0)
    except KeyboardInterrupt:
        fake.stop()


if __name__ == "__main__":
    main()
