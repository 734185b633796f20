"""ROS messages built from simulator state (no master needed)."""
import math
import os
import subprocess
import sys

import numpy as np
import pytest

from ascc_common.grid import OCCUPIED, GridInfo
from ascc_sim import messages as M
from ascc_sim.grid import GridMap
from ascc_sim.laser import LaserConfig
from ascc_sim.people import PersonState
from ascc_sim.world import load_world

PKG = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def test_laser_scan_fields():
    cfg = LaserConfig()
    ranges = np.array([1.0, np.inf, np.nan, -np.inf] + [2.0] * (cfg.n_beams - 4))
    msg = M.laser_scan(12.5, "robotA/laser", cfg, ranges)
    assert msg.header.frame_id == "robotA/laser"
    assert msg.header.stamp.to_sec() == pytest.approx(12.5)
    assert len(msg.ranges) == 683
    assert msg.angle_max == pytest.approx(msg.angle_min + 682 * msg.angle_increment)
    assert msg.time_increment == pytest.approx(0.1 / 1024)
    assert msg.ranges[0] == 1.0 and math.isinf(msg.ranges[1]) and math.isnan(msg.ranges[2])
    assert msg.ranges[3] == -math.inf


def test_occupancy_grid_layout():
    occ = np.zeros((3, 4), dtype=np.int8)
    occ[0, 3] = OCCUPIED  # row 0 = lowest y: the first row of OccupancyGrid.data
    occ[2, 0] = -1
    msg = M.occupancy_grid(GridMap(occ, GridInfo(0.5, 4, 3, -1.0, 2.0)), 0.0, "map")
    assert (msg.info.width, msg.info.height, msg.info.resolution) == (4, 3, 0.5)
    assert (msg.info.origin.position.x, msg.info.origin.position.y) == (-1.0, 2.0)
    assert msg.data[3] == 100 and msg.data[8] == -1 and sum(msg.data) == 99


def test_truth_and_frames():
    world = load_world(os.path.join(PKG, "worlds", "three_robots.yaml"))
    assert M.frame_names(world.robots[1]) == ("robotB/odom", "robotB/base_link",
                                              "robotB/laser")
    office = load_world(os.path.join(PKG, "worlds", "office.yaml"))
    assert M.frame_names(office.robots[0]) == ("odom", "base_link", "laser")
    odom = M.truth_odometry(3.0, "map", "robotB/base_link", 1.0, 2.0, math.pi / 2, 0.2, 0.1)
    assert odom.header.frame_id == "map" and odom.child_frame_id == "robotB/base_link"
    q = odom.pose.pose.orientation
    assert (q.z, q.w) == (pytest.approx(math.sqrt(0.5)), pytest.approx(math.sqrt(0.5)))
    assert odom.twist.twist.linear.x == 0.2 and odom.twist.twist.angular.z == 0.1
    tf = M.static_transform(0.0, "robotB/base_link", "robotB/laser", 0.05, 0.0, 0.3, 0.0)
    assert tf.child_frame_id == "robotB/laser" and tf.transform.translation.z == 0.3


def test_objects_and_markers():
    world = load_world(os.path.join(PKG, "worlds", "apartment.yaml"))
    objs = M.objects_array(0.0, "map", [M.world_object(o) for o in world.objects])
    bench = [o for o in objs.objects if o.name == "bench"][0]
    assert (bench.type, bench.kind, bench.solid) == ("furniture", "bench", True)
    assert len(bench.footprint.points) == 4
    xs = [p.x for p in bench.footprint.points]
    assert min(xs) == pytest.approx(3.83 - 0.25, abs=1e-3)
    spec = world.people[0]
    person = M.person_object(spec, PersonState(4.45, 5.5, 0.0, 0.0, "lie"))
    assert (person.type, person.activity, person.radius) == ("person", "lie", spec.radius_m)
    builder = M.MarkerBuilder(world, "map", 0.165)
    markers = builder.markers(1.0, [("asccbot", 5.8, 3.3, 1.57)],
                              [(spec, PersonState(4.45, 5.5, 0.0, 0.0, "lie"))])
    ids = {(m.ns, m.id) for m in markers.markers}
    assert len(ids) == len(markers.markers)  # no two markers overwrite each other
    assert all(m.header.frame_id == "map" for m in markers.markers)
    assert any(m.ns == "people_labels" and "lie" in m.text for m in markers.markers)


def test_check_world_cli(tmp_path):
    script = os.path.join(PKG, "scripts", "check_world.py")
    ok = subprocess.run([sys.executable, script, os.path.join(PKG, "worlds", "lab.yaml")],
                        capture_output=True, text=True)
    assert ok.returncode == 0 and ok.stdout.startswith("ok ")
    bad = tmp_path / "bad.yaml"
    bad.write_text("map: %s\nrobots:\n  - {name: r, pose: [0.6, 3.5, 0.0]}\n"
                   % os.path.join(PKG, "worlds", "maps", "lab.yaml"))
    out = subprocess.run([sys.executable, script, str(bad)], capture_output=True, text=True)
    assert out.returncode == 1
    lines = out.stdout.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in out.stdout + out.stderr
    assert lines[0].startswith("ERROR %s: robots[0].pose: " % bad)
    assert "overlaps a wall" in lines[0]


def test_camera_messages_round_trip():
    from io import BytesIO

    import cv2
    from sensor_msgs.msg import CameraInfo, CompressedImage, Image

    from ascc_common.camera_model import PanoramicCamera

    cam = PanoramicCamera()
    img = np.zeros((768, 1024, 3), np.uint8)
    img[10, 20] = (1, 2, 3)
    msgs = [M.image_bgr8(3.0, "robotA/camera", img),
            M.compressed_jpeg(3.0, "robotA/camera", cv2.imencode(".jpg", img)[1].tobytes()),
            M.camera_info(3.0, "robotA/camera", cam)]
    out = []
    for msg, cls in zip(msgs, (Image, CompressedImage, CameraInfo)):
        buf = BytesIO()
        msg.serialize(buf)
        out.append(cls().deserialize(buf.getvalue()))
    image, jpeg, info = out
    assert (image.height, image.width, image.encoding, image.step) == (768, 1024, "bgr8", 3072)
    back = np.frombuffer(image.data, np.uint8).reshape(768, 1024, 3)
    assert tuple(back[10, 20]) == (1, 2, 3)
    assert jpeg.format == "bgr8; jpeg compressed bgr8"
    assert cv2.imdecode(np.frombuffer(jpeg.data, np.uint8), cv2.IMREAD_COLOR).shape == img.shape
    assert (info.width, info.height, info.distortion_model) == (1024, 768, "equirectangular")
    # K maps bearing 0 / elevation 0 to the top strip's centre, f = px_per_rad
    assert info.K[0] == pytest.approx(cam.px_per_rad) and info.K[4] == info.K[0]
    assert (info.K[2], info.K[5]) == pytest.approx((512.0, 192.0))
    assert all(m.header.frame_id == "robotA/camera" for m in out)
