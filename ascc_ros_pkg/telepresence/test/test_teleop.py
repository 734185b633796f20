"""The operator GUI's rules without Qt or a master: lease, e-stop, addresses, map view,
grid image, video statistics."""
import math
import threading
import xmlrpc.server

import numpy as np
import pytest

from ascc_common.grid import GridInfo
from ascc_common.ports import free_port
from telepresence.teleop import (
    BACKWARD,
    FORWARD,
    LEFT,
    RIGHT,
    DriveLease,
    EmergencyStop,
    FrameStats,
    MapView,
    PathTrail,
    check_master,
    decode_jpeg,
    goal_pose,
    grid_image,
    master_uri,
    namespace,
)


def lease():
    d = DriveLease(0.4, 1.2)
    d.set_speed(0.5)
    return d


def test_nothing_is_published_before_a_press():
    d = lease()
    assert d.tick() is None and d.tick() is None


def test_held_direction_repeats_its_command_then_one_zero_on_release():
    d = lease()
    d.press(FORWARD)
    assert d.tick() == pytest.approx((0.2, 0.0))
    assert d.tick() == pytest.approx((0.2, 0.0))
    d.release(FORWARD)
    assert d.tick() == (0.0, 0.0)
    assert d.tick() is None


def test_directions_combine_and_cancel():
    d = lease()
    d.press(FORWARD)
    d.press(LEFT)
    assert d.tick() == pytest.approx((0.2, 0.6))
    d.press(BACKWARD)
    assert d.tick() == pytest.approx((0.0, 0.6))
    d.release(LEFT)
    d.press(RIGHT)
    assert d.tick() == pytest.approx((0.0, -0.6))


def test_speed_is_clamped_to_the_limits():
    d = lease()
    d.set_speed(3.0)
    d.press(BACKWARD)
    assert d.tick() == pytest.approx((-0.4, 0.0))
    d.set_speed(-1.0)
    assert d.tick() == pytest.approx((0.0, 0.0))
    with pytest.raises(ValueError):
        d.set_speed(float("nan"))
    with pytest.raises(ValueError):
        DriveLease(0.0, 1.0)


def test_button_and_key_holding_the_same_direction():
    d = lease()
    d.press(FORWARD)  # button
    d.press(FORWARD)  # key
    d.release(FORWARD)
    assert d.tick() == pytest.approx((0.2, 0.0))
    d.release(FORWARD)
    assert d.tick() == (0.0, 0.0)


@pytest.mark.parametrize("drop", ["focus", "link"])
def test_focus_loss_or_link_drop_stops_and_needs_a_new_press(drop):
    d = lease()
    d.press(LEFT)
    assert d.tick() == pytest.approx((0.0, 0.6))
    getattr(d, "set_" + drop)(False)
    assert d.tick() == (0.0, 0.0)
    assert d.tick() is None
    getattr(d, "set_" + drop)(True)
    assert d.tick() is None  # the held key was released with the focus / link
    d.press(LEFT)
    assert d.tick() == pytest.approx((0.0, 0.6))


def test_unknown_direction_is_named():
    with pytest.raises(ValueError, match="up"):
        lease().press("up")


def test_emergency_stop_is_latched_until_rearmed():
    d = lease()
    e = EmergencyStop(d)
    d.press(FORWARD)
    assert d.tick() == pytest.approx((0.2, 0.0))
    assert e.engage() is True
    assert d.tick() == (0.0, 0.0)
    d.press(FORWARD)
    assert d.tick() is None and d.tick() is None  # pressing does nothing while stopped
    d.release(FORWARD)
    assert e.rearm() is False
    assert d.tick() is None  # re-arming alone does not drive
    d.press(FORWARD)
    assert d.tick() == pytest.approx((0.2, 0.0))


@pytest.mark.parametrize("text,uri", [
    ("192.168.1.20", "http://192.168.1.20:11311/"),
    ("fitpc2:11312", "http://fitpc2:11312/"),
    (" http://fitpc2:11311 ", "http://fitpc2:11311/"),
    ("http://[::1]:11311/", "http://[::1]:11311/"),
])
def test_master_uri(text, uri):
    assert master_uri(text) == uri


@pytest.mark.parametrize("text", ["", "https://a:1/", "http://host:x/", "host:11311/path"])
def test_bad_master_uri_is_named(text):
    with pytest.raises(ValueError, match="address"):
        master_uri(text)


def test_namespace():
    assert namespace("") == "/" and namespace("/") == "/"
    assert namespace("robotA") == "/robotA" and namespace("/a/b_2/") == "/a/b_2"
    with pytest.raises(ValueError):
        namespace("2robot")
    with pytest.raises(ValueError):
        namespace("a b")


def test_unreachable_master_is_reported_within_its_timeout():
    port = free_port()  # nothing listens on it
    ok, text, pid = check_master("http://127.0.0.1:%d/" % port, 0.3)
    assert not ok and pid is None and "unreachable" in text


def test_silent_host_times_out():
    import socket
    import time
    s = socket.socket()
    s.bind(("127.0.0.1", 0))
    s.listen(1)  # accepts the connection, never answers
    t0 = time.monotonic()
    ok, text, _ = check_master("http://127.0.0.1:%d/" % s.getsockname()[1], 0.3)
    took = time.monotonic() - t0
    s.close()
    assert not ok and "unreachable" in text
    assert "timed out" in text  # the socket's own timeout ended it, not a reset
    assert took < 10.0  # an end, not a hang (the default socket would wait forever)


def test_an_xmlrpc_server_answering_getpid_counts_as_master():
    server = xmlrpc.server.SimpleXMLRPCServer(("127.0.0.1", 0), logRequests=False)
    server.register_function(lambda caller: [1, "", 4242], "getPid")
    threading.Thread(target=server.handle_request, daemon=True).start()
    # a timeout long enough for the server thread on a loaded machine: not what is tested
    ok, text, pid = check_master("http://127.0.0.1:%d/" % server.server_address[1], 10.0)
    server.server_close()
    assert ok and pid == 4242 and "4242" in text


def test_grid_image_colours_flip_and_downscale():
    grid = np.full((40, 60), -1, dtype=np.int8)
    grid[0, :] = 100   # the map's bottom row: occupied
    grid[-1, :] = 0    # top row: free
    img, scale = grid_image(grid, 1000)
    assert scale == 1.0 and img.shape == (40, 60) and img.dtype == np.uint8
    assert (img[-1] == 0).all() and (img[0] == 254).all() and img[20, 30] == 205
    grid[5, 5] = 50
    assert grid_image(grid, 1000)[0][34, 5] == 127
    small, scale = grid_image(np.zeros((4000, 2000), dtype=np.int8), 500)
    assert small.shape == (500, 250) and scale == pytest.approx(8.0)
    with pytest.raises(ValueError):
        grid_image(np.zeros((0, 3), dtype=np.int8), 10)


def test_map_view_round_trip_and_fit():
    info = GridInfo(0.05, 200, 100, -3.0, 1.0)  # 10 m x 5 m
    view = MapView(info, 400, 400)
    assert view.px_per_m == pytest.approx(40.0)
    assert view.rect() == pytest.approx((0.0, 100.0, 400.0, 200.0))
    px, py = view.to_pixel(-3.0, 6.0)  # top left corner
    assert (float(px), float(py)) == pytest.approx((0.0, 100.0))
    px, py = view.to_pixel(2.0, 3.5)  # centre
    assert (float(px), float(py)) == pytest.approx((200.0, 200.0))
    for x, y in ((0.3, 2.2), (-2.9, 5.9), (6.9, 1.1)):
        assert view.to_map(*map(float, view.to_pixel(x, y))) == pytest.approx((x, y))
    assert view.inside(200, 200) and not view.inside(200, 50) and not view.inside(200, 350)


def test_goal_faces_away_from_the_robot():
    assert goal_pose(2.0, 1.0) == (2.0, 1.0, 0.0)
    x, y, yaw = goal_pose(0.0, 2.0, (0.0, 0.0, 1.0))
    assert (x, y) == (0.0, 2.0) and yaw == pytest.approx(math.pi / 2)
    assert goal_pose(1.0, 1.0, (1.0, 1.0, 0.3))[2] == pytest.approx(0.3)


def test_path_trail_keeps_a_point_per_step_and_the_newest():
    t = PathTrail(0.1, 3)
    for x in (0.0, 0.05, 0.12, 0.25, 0.4, 0.42):
        t.add(x, 0.0)
    assert [p[0] for p in t.points] == [0.12, 0.25, 0.4]


def test_frame_stats_rate_and_age():
    s = FrameStats(window_s=2.0)
    assert s.fps(0.0) == 0.0 and s.age(0.0) is None
    for i in range(31):  # 10 fps for 3 s, each shown 0.12 s after its stamp
        assert s.add(i * 0.1, i * 0.1 + 0.12) == pytest.approx(0.12)
    assert s.fps(3.12) == pytest.approx(10.0, rel=0.06)
    assert s.age(3.5) == pytest.approx(0.5)
    assert s.fps(10.0) == 0.0  # nothing shown for long: no rate
    s.add(0.0, 0.05)  # time went back (a restarted simulator)
    assert s.fps(0.05) == 0.0


def test_decode_jpeg():
    import cv2
    img = np.zeros((24, 32, 3), dtype=np.uint8)
    img[:, :16] = (255, 0, 0)
    ok, buf = cv2.imencode(".jpg", img)
    out = decode_jpeg(buf.tobytes())
    assert out.shape == (24, 32, 3) and out[12, 4, 0] > 200 and out[12, 28, 0] < 50
    assert decode_jpeg(b"") is None and decode_jpeg(b"not a jpeg") is None
