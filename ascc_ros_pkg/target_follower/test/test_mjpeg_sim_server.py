"""The camera driver's reader (target_follower.mjpeg) against the simulator's MJPEG server
(ascc_sim.mjpeg_server.MjpegServer) over real loopback sockets: frames arrive
byte-identical, and after the connection is dropped (by the client, or by the server
stopping) a new connection reads frames again."""
import threading

import cv2
import numpy as np
import pytest

from ascc_sim.mjpeg_server import MjpegServer
from target_follower import mjpeg

TIMEOUT_S = 2.0


def jpeg(i):
    """A distinct, decodable JPEG per ``i`` (a number drawn into a noisy image)."""
    rng = np.random.default_rng(i)
    img = rng.integers(0, 255, size=(48, 64, 3), dtype=np.uint8)
    cv2.putText(img, str(i), (4, 40), cv2.FONT_HERSHEY_SIMPLEX, 1.2, (255, 255, 255), 2)
    ok, buf = cv2.imencode(".jpg", img, [cv2.IMWRITE_JPEG_QUALITY, 85])
    assert ok
    return buf.tobytes()


class Producer:
    """Publishes numbered JPEGs to the server every ``period_s`` until stopped; keeps
    what it sent."""

    def __init__(self, server, period_s=0.02):
        self.server = server
        self.period_s = period_s
        self.sent = []
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)

    def _run(self):
        i = 0
        while not self._stop.is_set():
            data = jpeg(i)
            self.sent.append(data)
            self.server.publish(data)
            i += 1
            self._stop.wait(self.period_s)

    def __enter__(self):
        self._thread.start()
        return self

    def __exit__(self, *exc):
        self._stop.set()
        self._thread.join(timeout=5.0)


def take(url, n):
    frames = []
    for frame in mjpeg.iter_url(url, TIMEOUT_S):  # closes the response when left
        frames.append(frame)
        if len(frames) == n:
            break
    return frames


def assert_byte_identical(frames, sent):
    """Each frame of one connection is one the producer sent, in order, none twice, and
    it decodes."""
    index = {data: i for i, data in enumerate(sent)}
    seen = []
    for f in frames:
        assert f.data in index, "received %d bytes never sent" % len(f.data)
        seen.append(index[f.data])
        assert f.headers.get("content-type") == "image/jpeg"
        assert int(f.headers["content-length"]) == len(f.data)
        img = cv2.imdecode(np.frombuffer(f.data, np.uint8), cv2.IMREAD_COLOR)
        assert img is not None and img.shape == (48, 64, 3)
    assert seen == sorted(set(seen))


@pytest.fixture
def server():
    s = MjpegServer(port=0, path="/faststream.jpg")
    s.start()
    yield s
    s.stop()


def url_of(server):
    return "http://127.0.0.1:%d/faststream.jpg?stream=full&needlength" % server.port


def test_frames_byte_identical(server):
    with Producer(server) as producer:
        frames = take(url_of(server), 10)
    assert len(frames) == 10
    assert_byte_identical(frames, list(producer.sent))
    stamps = [f.monotonic_s for f in frames]
    assert stamps == sorted(stamps)


def test_reconnect_after_client_close(server):
    with Producer(server) as producer:
        first = take(url_of(server), 5)  # leaving the generator closes the connection
        second = take(url_of(server), 5)  # a new connection
        sent = list(producer.sent)
    assert len(first) == 5 and len(second) == 5
    assert_byte_identical(first, sent)
    assert_byte_identical(second, sent)
    # a new connection starts at the newest frame (possibly the last one already read)
    assert sent.index(second[0].data) >= sent.index(first[-1].data)


def test_new_server_after_stop_serves_again():
    """stop() ends the stream (the reader sees it end or break, not hang); a server
    started again on the same port serves a new connection."""
    first_server = MjpegServer(port=0, path="/faststream.jpg")
    port = first_server.start()
    url = "http://127.0.0.1:%d/faststream.jpg" % port
    got = []
    error = []
    try:
        with Producer(first_server) as producer:
            stream = mjpeg.iter_url(url, TIMEOUT_S)
            got.append(next(stream))
            first_server.stop()
            try:
                for frame in stream:  # the remaining frames already sent, then the end
                    got.append(frame)
            except mjpeg.MjpegError as exc:  # or the connection breaks inside a part
                error.append(exc)
            sent = list(producer.sent)
    finally:
        first_server.stop()
    assert_byte_identical(got, sent)
    assert not error or not isinstance(error[0], mjpeg.StreamStalled)
    with pytest.raises(mjpeg.ConnectError):
        take(url, 1)
    second_server = MjpegServer(port=port, path="/faststream.jpg")
    second_server.start()
    try:
        with Producer(second_server) as producer:
            frames = take(url, 5)
            sent = list(producer.sent)
    finally:
        second_server.stop()
    assert len(frames) == 5
    assert_byte_identical(frames, sent)


def test_wrong_path_is_404(server):
    with pytest.raises(mjpeg.HttpStatusError) as err:
        take("http://127.0.0.1:%d/other" % server.port, 1)
    assert err.value.status == 404
