"""The MJPEG reader (target_follower.mjpeg) against the fake Q24 over real loopback
sockets, and on recorded bytes: boundary forms, parts with and without Content-Length,
truncated parts, HTML, 404, a stalled stream, credentials in the URL."""
import io
import os
import socket
import sys
import threading
import time

import pytest

from ascc_common.ports import free_port
from target_follower import mjpeg

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from fake_q24 import FakeQ24, make_jpeg, numbered  # noqa: E402  (helper next to this file)

TIMEOUT_S = 1.0


@pytest.fixture
def fake():
    servers = []

    def start(**kwargs):
        server = FakeQ24(**kwargs)
        server.start()
        servers.append(server)
        return server

    yield start
    for server in servers:
        server.stop()


def take(url, n, timeout_s=TIMEOUT_S):
    frames = []
    for frame in mjpeg.iter_url(url, timeout_s):
        frames.append(frame)
        if len(frames) == n:
            break
    return frames


def assert_served(server, frames):
    """Every frame is byte-identical to one the server sent, in order, none twice."""
    sent = {s.data: s for s in server.sent_frames(good_only=False)}
    indices = []
    for f in frames:
        assert f.data in sent, "received %d bytes never sent" % len(f.data)
        indices.append(sent[f.data].index)
    assert indices == sorted(set(indices))


# --- the Content-Type's boundary ------------------------------------------------------------
@pytest.mark.parametrize("content_type, boundary", [
    ("multipart/x-mixed-replace; boundary=myboundary", b"myboundary"),
    ('multipart/x-mixed-replace; boundary="my boundary"', b"my boundary"),
    ("multipart/x-mixed-replace;boundary=--myboundary", b"myboundary"),
    ('Multipart/X-Mixed-Replace; charset=x; Boundary="--b"', b"b"),
])
def test_parse_boundary_forms(content_type, boundary):
    assert mjpeg.parse_boundary(content_type) == boundary


@pytest.mark.parametrize("content_type", ["text/html; charset=utf-8", "image/jpeg", "",
                                          "multipart/x-mixed-replace",
                                          "multipart/x-mixed-replace; boundary=--"])
def test_parse_boundary_rejects(content_type):
    with pytest.raises(mjpeg.NotMultipartError):
        mjpeg.parse_boundary(content_type)


# --- streams over sockets --------------------------------------------------------------------
@pytest.mark.parametrize("options", [
    dict(),
    dict(content_length=False),
    dict(header_boundary='"q24frame"'),
    dict(header_boundary="--q24frame", body_dashes=True),
    dict(body_dashes=False),
    dict(body_dashes=False, content_length=False),
], ids=["length", "no-length", "quoted", "dashes-in-header", "no-dashes", "no-dashes-no-length"])
def test_frames_arrive_untouched(fake, options):
    server = fake(fps=50.0, **options)
    frames = take(server.url, 5)
    assert len(frames) == 5
    assert_served(server, frames)
    assert frames[0].headers["content-type"] == "image/jpeg"
    assert ("content-length" in frames[0].headers) == options.get("content_length", True)


def test_body_with_line_breaks_and_boundary_text_without_length(fake):
    """Without Content-Length only a whole delimiter line ends a part: a JPEG holding
    CRLFs and the boundary's text mid-line is passed through intact."""
    jpeg = make_jpeg(64, 48)
    trap = b"\r\n\r\nxx--q24frame\r\n--q24frameX\r\n\n"
    data = jpeg[:2] + b"\xff\xfe" + (len(trap) + 2).to_bytes(2, "big") + trap + jpeg[2:]
    server = fake(fps=50.0, content_length=False, jpeg=data)
    frames = take(server.url, 3)
    assert_served(server, frames)
    assert trap in frames[0].data


def test_stamp_is_when_the_first_byte_arrived():
    """Over a real socket, each part's stamps are taken when its first header line is in,
    before its body exists: the sender waits for the stamps (the wall one is taken last)
    before it sends the body (no timing bound, so a loaded machine cannot fail it; a
    reader that stamped at the end would take its stamps only after the sender's 5 s
    wait, after the body was sent)."""
    jpeg = make_jpeg(64, 48)
    parts = [numbered(jpeg, i) for i in range(3)]
    stamped = threading.Event()
    body_sent = []  # (monotonic, wall) when each part's body was sent
    a, b = socket.socketpair()

    def send():
        a.sendall(b"--rec\r\n")
        for i, data in enumerate(parts):
            stamped.clear()
            a.sendall(b"Content-Type: image/jpeg\r\n")
            stamped.wait(5.0)
            body_sent.append((time.monotonic(), time.time()))
            a.sendall(b"Content-Length: %d\r\n\r\n" % len(data) + data + b"\r\n--rec"
                      + (b"--\r\n" if i == len(parts) - 1 else b"\r\n"))
        a.close()

    def wall_clock():  # read_frames takes the wall stamp after the monotonic one
        now = time.time()
        stamped.set()
        return now

    thread = threading.Thread(target=send)
    thread.start()
    b.settimeout(10.0)
    with b.makefile("rb") as stream:
        frames = list(mjpeg.read_frames(stream, "multipart/x-mixed-replace; boundary=rec",
                                        wall_clock=wall_clock))
    thread.join()
    b.close()
    assert [f.data for f in frames] == parts
    for f, (sent_mono, sent_wall) in zip(frames, body_sent):
        assert f.monotonic_s <= sent_mono, (f.monotonic_s, sent_mono)
        assert f.wall_s <= sent_wall, (f.wall_s, sent_wall)
    assert all(x.monotonic_s < y.monotonic_s for x, y in zip(frames, frames[1:]))


@pytest.mark.parametrize("with_length", [True, False], ids=["length", "no-length"])
def test_stamp_is_the_clock_at_the_parts_first_line(with_length):
    """A clock that counts the bytes read so far: each part is stamped just after its
    first header line, whether its end is found by Content-Length or by the delimiter."""
    jpeg = make_jpeg(32, 24)
    body = recording([(numbered(jpeg, i), with_length) for i in range(4)])
    stream = io.BytesIO(body)
    frames = list(mjpeg.read_frames(stream, "multipart/x-mixed-replace; boundary=rec",
                                    clock=lambda: float(stream.tell())))
    first_lines, at = [], 0
    while True:
        at = body.find(b"--rec\r\nContent-Type", at)
        if at < 0:
            break
        first_lines.append(float(at + len(b"--rec\r\nContent-Type: image/jpeg\r\n")))
        at += 1
    assert [f.monotonic_s for f in frames] == first_lines


def test_html_page_is_not_a_stream(fake):
    server = fake()
    with pytest.raises(mjpeg.NotMultipartError, match="text/html"):
        take("http://127.0.0.1:%d/page.html" % server.port, 1)
    server.answer = "html"
    with pytest.raises(mjpeg.NotMultipartError, match=str(server.port)):
        take(server.url, 1)


def test_404_names_the_status_and_url(fake):
    server = fake()
    url = "http://127.0.0.1:%d/control/faststream.jpg?stream=full" % server.port
    with pytest.raises(mjpeg.HttpStatusError, match="404") as err:
        take(url, 1)
    assert err.value.status == 404
    assert "faststream.jpg" in str(err.value)


def test_connection_refused():
    port = free_port()  # a port nobody listens on
    with pytest.raises(mjpeg.ConnectError, match=str(port)):
        take("http://127.0.0.1:%d/stream" % port, 1)


def test_stall_raises_after_the_read_timeout(fake):
    server = fake(fps=50.0)
    server.stall_after = 3
    t0 = time.monotonic()
    frames = []
    with pytest.raises(mjpeg.StreamStalled, match="no data"):
        for f in mjpeg.iter_url(server.url, 0.5):
            frames.append(f)
    waited = time.monotonic() - frames[-1].monotonic_s
    assert len(frames) == 3
    assert 0.45 <= waited < 5.0, waited
    assert time.monotonic() - t0 < 10.0


@pytest.mark.parametrize("content_length", [True, False])
def test_connection_dropped_mid_frame_is_a_truncated_part(fake, content_length):
    server = fake(fps=50.0, content_length=content_length)
    server.cut_after = 2
    frames = []
    with pytest.raises(mjpeg.TruncatedPart, match="inside a frame"):
        for f in mjpeg.iter_url(server.url, TIMEOUT_S):
            frames.append(f)
    assert len(frames) == 2
    assert_served(server, frames)


def test_reconnect_after_a_drop_gets_new_frames(fake):
    server = fake(fps=50.0)
    first = []
    with pytest.raises(mjpeg.TruncatedPart):
        for f in mjpeg.iter_url(server.url, TIMEOUT_S):
            first.append(f)
            if len(first) == 2:
                server.cut_now()  # this open connection breaks inside a later part
    again = take(server.url, 2)
    assert_served(server, first + again)
    assert server.connections == 2


def test_credentials_become_basic_auth_and_are_redacted():
    url = "http://admin:s%40cret@10.8.0.118:8080/control/faststream.jpg?stream=full"
    clean, auth = mjpeg.split_credentials(url)
    assert clean == "http://10.8.0.118:8080/control/faststream.jpg?stream=full"
    assert auth == "Basic YWRtaW46c0BjcmV0"  # base64 of admin:s@cret
    assert mjpeg.redact(url) == \
        "http://admin:***@10.8.0.118:8080/control/faststream.jpg?stream=full"
    assert mjpeg.split_credentials("http://cam/x") == ("http://cam/x", None)
    assert mjpeg.redact("http://cam/x") == "http://cam/x"


def test_basic_auth_header_reaches_the_server(fake):
    server = fake(fps=50.0)
    seen = []
    original = server._serve

    def spy(handler):
        seen.append(handler.headers.get("Authorization"))
        original(handler)

    server._serve = spy
    take("http://user:pw@127.0.0.1:%d/stream" % server.port, 1)
    assert seen == ["Basic dXNlcjpwdw=="]


# --- recorded bytes ---------------------------------------------------------------------------
def recording(parts, boundary=b"rec", close=True):
    body = b"preamble text\r\n"
    for data, with_length in parts:
        body += b"--" + boundary + b"\r\nContent-Type: image/jpeg\r\n"
        if with_length:
            body += b"Content-Length: %d\r\n" % len(data)
        body += b"\r\n" + data + b"\r\n"
    return body + (b"--" + boundary + b"--\r\n" if close else b"")


def test_recording_mixed_parts_and_close_delimiter():
    jpeg = make_jpeg(32, 24)
    parts = [(numbered(jpeg, i), i % 2 == 0) for i in range(5)]
    clock = iter(range(100))
    frames = list(mjpeg.read_frames(io.BytesIO(recording(parts)),
                                    "multipart/x-mixed-replace; boundary=rec",
                                    clock=lambda: float(next(clock))))
    assert [f.data for f in frames] == [p[0] for p in parts]
    assert all(a.monotonic_s < b.monotonic_s for a, b in zip(frames, frames[1:]))


def test_recording_truncated_inside_headers_and_bad_length():
    jpeg = make_jpeg(32, 24)
    whole = recording([(jpeg, True)], close=False)
    with pytest.raises(mjpeg.TruncatedPart, match="headers"):
        list(mjpeg.read_frames(io.BytesIO(whole + b"--rec\r\nContent-Type: image/jpeg\r\n"),
                               "multipart/x-mixed-replace; boundary=rec"))
    bad = b"--rec\r\nContent-Length: lots\r\n\r\n" + jpeg
    with pytest.raises(mjpeg.ProtocolError, match="Content-Length"):
        list(mjpeg.read_frames(io.BytesIO(bad), "multipart/x-mixed-replace; boundary=rec"))


def test_recording_without_any_delimiter_ends_empty():
    frames = list(mjpeg.read_frames(io.BytesIO(b"<html>nothing</html>\n"),
                                    "multipart/x-mixed-replace; boundary=rec"))
    assert frames == []


def test_reader_survives_slow_trickle(fake):
    """A part arriving in small pieces (a slow link) is reassembled."""
    jpeg = make_jpeg(64, 48)
    part = recording([(jpeg, True)], close=True)
    a, b = socket.socketpair()

    def trickle():
        for i in range(0, len(part), 97):
            a.sendall(part[i:i + 97])
            time.sleep(0.001)
        a.close()

    thread = threading.Thread(target=trickle)
    thread.start()
    b.settimeout(2.0)
    with b.makefile("rb") as stream:
        frames = list(mjpeg.read_frames(stream, "multipart/x-mixed-replace; boundary=rec"))
    thread.join()
    b.close()
    assert [f.data for f in frames] == [jpeg]
