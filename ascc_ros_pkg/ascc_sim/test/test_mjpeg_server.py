"""The MJPEG server against a plain urllib client: the multipart format, newest frame
first, 404 elsewhere, and a client that disconnects does not break the others."""
import threading
import time
import urllib.error
import urllib.request

import cv2
import numpy as np
import pytest

from ascc_sim.mjpeg_server import MjpegServer


def jpeg(value):
    img = np.full((48, 64, 3), value, np.uint8)
    return cv2.imencode(".jpg", img)[1].tobytes()


def read_part(resp, boundary):
    """One multipart part: (headers dict, body bytes)."""
    line = resp.readline()
    while line in (b"\r\n", b"\n"):
        line = resp.readline()
    assert line.rstrip(b"\r\n") == b"--" + boundary.encode()
    headers = {}
    while True:
        line = resp.readline().rstrip(b"\r\n")
        if not line:
            break
        key, value = line.decode().split(":", 1)
        headers[key.strip().lower()] = value.strip()
    body = resp.read(int(headers["content-length"]))
    assert resp.read(2) == b"\r\n"
    return headers, body


@pytest.fixture
def server():
    s = MjpegServer(port=0, path="/stream", boundary="myboundary")
    s.start()
    stop = threading.Event()

    def produce():
        k = 0
        while not stop.is_set():
            s.publish(jpeg(k % 250))
            k += 1
            time.sleep(0.02)

    t = threading.Thread(target=produce, daemon=True)
    t.start()
    yield s
    stop.set()
    t.join()
    s.stop()


def test_serves_decodable_frames_in_the_mobotix_format(server):
    assert server.port > 0
    url = "http://127.0.0.1:%d/stream" % server.port
    with urllib.request.urlopen(url, timeout=5) as resp:
        assert resp.status == 200
        ctype = resp.headers["Content-Type"]
        assert ctype == "multipart/x-mixed-replace; boundary=myboundary"
        values = []
        for _ in range(2):
            headers, body = read_part(resp, "myboundary")
            assert headers["content-type"] == "image/jpeg"
            img = cv2.imdecode(np.frombuffer(body, np.uint8), cv2.IMREAD_COLOR)
            assert img.shape == (48, 64, 3)
            values.append(int(img.mean()))
        assert values[0] != values[1]  # two different (newer) frames


def test_other_paths_answer_404(server):
    with pytest.raises(urllib.error.HTTPError) as err:
        urllib.request.urlopen("http://127.0.0.1:%d/other" % server.port, timeout=5)
    assert err.value.code == 404


def test_a_client_that_disconnects_does_not_break_the_server(server):
    url = "http://127.0.0.1:%d/stream" % server.port
    for _ in range(3):
        resp = urllib.request.urlopen(url, timeout=5)
        read_part(resp, "myboundary")
        resp.close()  # mid-stream
    time.sleep(0.2)  # the server writes into the closed sockets meanwhile
    with urllib.request.urlopen(url, timeout=5) as resp:
        _, body = read_part(resp, "myboundary")
        assert cv2.imdecode(np.frombuffer(body, np.uint8), cv2.IMREAD_COLOR) is not None


def test_newest_frame_wins_and_stop_ends_clients():
    s = MjpegServer(port=0)
    port = s.start()
    s.publish(jpeg(10))
    s.publish(jpeg(200))  # replaces the first before anyone read it
    resp = urllib.request.urlopen("http://127.0.0.1:%d/" % port, timeout=5)
    _, body = read_part(resp, "ascc_sim_frame")
    assert cv2.imdecode(np.frombuffer(body, np.uint8), cv2.IMREAD_GRAYSCALE).mean() > 150
    s.stop()
    assert resp.read() == b""  # the stream ends
    resp.close()
