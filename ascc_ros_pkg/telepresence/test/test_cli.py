"""record_gesture_template (telepresence.cli): from the simulated person and from a bag of
openni_tracker-like /tf, the same template; bad input named with exit status 2."""
import io
import os

import numpy as np
import pytest
import rospy
from geometry_msgs.msg import TransformStamped
from rosbags.rosbag1 import Writer
from tf2_msgs.msg import TFMessage

from telepresence.cli import bag_frames, recognize_main, record_main
from telepresence.gestures import GestureParams, GestureRecognizer, load_template
from telepresence.recording import record_sim_template
from telepresence.skeleton_sim import SensorParams, SkeletonSource, script_of

PKG = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def write_skeleton_bag(path, source, t0=100.0, rate_hz=30.0, per_joint=True):
    """The source's frames as openni_tracker sends them: one /tf message per joint, each
    stamped a little later (``per_joint``)."""
    with Writer(path) as w:
        conn = w.add_connection("/tf", "tf2_msgs/msg/TFMessage", msgdef=TFMessage._full_text,
                                md5sum=TFMessage._md5sum)
        for t in np.arange(0.0, source.end_s, 1.0 / rate_hz):
            f = source.frame(float(t))
            if f is None:
                continue
            for i, (name, xyz) in enumerate(f.joints.items()):
                tr = TransformStamped()
                stamp = t0 + t + (0.0005 * i if per_joint else 0.0)
                tr.header.stamp = rospy.Time.from_sec(stamp)
                tr.header.frame_id = "openni_depth_frame"
                tr.child_frame_id = "%s_%d" % (name, f.user)
                tr.transform.translation.x, tr.transform.translation.y, \
                    tr.transform.translation.z = (float(v) for v in xyz)
                tr.transform.rotation.w = 1.0
                buf = io.BytesIO()
                TFMessage([tr]).serialize(buf)
                w.write(conn, int(stamp * 1e9), buf.getvalue())


def test_sim_template_written_and_loadable(tmp_path, capsys):
    out = str(tmp_path / "cc.yaml")
    assert record_main(["come_close", "--sim", "--seed", "1", "-o", out]) == 0
    tp = load_template(out)
    assert tp.command == "come_close" and "seed 1" in tp.source
    assert 1.5 < tp.duration_s < 2.1  # two cycles at 1.1 Hz
    assert np.ptp(tp.pitch) > 0.6  # the beckoning swing
    assert "28 samples" in capsys.readouterr().out


def test_bag_template_equals_the_sim_recording(tmp_path):
    """The same performance through a bag (per-joint stamps, frames assembled as the node
    does) gives the same template as the direct recording."""
    script = script_of(["rest", "go_away", "rest"], 1, nominal=True)
    sensor = SensorParams(lost_per_min=0.0)
    bag = str(tmp_path / "run.bag")
    write_skeleton_bag(bag, SkeletonSource(script, sensor, 1))
    g = script[1]
    out = str(tmp_path / "ga.yaml")
    start, end = g.t0 + 0.5, g.motion_end
    assert record_main(["go_away", "--bag", bag, "--start", str(start), "--end", str(end),
                        "-o", out]) == 0
    from_bag = load_template(out)
    direct = record_sim_template("go_away", 1)
    n = min(len(from_bag.yaw), len(direct.yaw))
    assert abs(len(from_bag.yaw) - len(direct.yaw)) <= 1
    assert np.sqrt(np.mean((from_bag.pitch[:n] - direct.pitch[:n]) ** 2)) < 0.03


def test_bag_frames_one_per_tracker_frame(tmp_path):
    src = SkeletonSource(script_of(["rest"], 2), SensorParams(drop_prob=0.0,
                                                               lost_per_min=0.0), 2)
    bag = str(tmp_path / "rest.bag")
    write_skeleton_bag(bag, src)
    frames = list(bag_frames(bag))
    assert len(frames) == len(np.arange(0.0, src.end_s, 1.0 / 30.0))
    assert all(len(j) >= 14 for _, _, j in frames)


@pytest.mark.parametrize("args, words", [
    (["--bag", "/nonexistent.bag", "--start", "0", "--end", "1"], "nonexistent"),
])
def test_bad_input_named_exit_2(tmp_path, capsys, args, words):
    assert record_main(["come_close", "-o", str(tmp_path / "x.yaml")] + args) == 2
    assert words in capsys.readouterr().err


def test_bag_without_skeleton_exit_2(tmp_path, capsys):
    bag = str(tmp_path / "empty.bag")
    with Writer(bag) as w:
        w.add_connection("/tf", "tf2_msgs/msg/TFMessage", msgdef=TFMessage._full_text,
                         md5sum=TFMessage._md5sum)
    assert record_main(["go_away", "--bag", bag, "--start", "0", "--end", "2", "-o",
                        str(tmp_path / "x.yaml")]) == 2
    assert "no usable skeleton frames" in capsys.readouterr().err


def test_recognize_gestures_prints_each_gesture_like_the_node(tmp_path, capsys):
    """A bag of a scripted performance (held-out seed 21): one line per gesture, time
    inside the gesture, the same as the recognizer on the frames directly."""
    script = script_of(["rest", "come_close", "rest", "scratch", "rest", "go_away", "rest"],
                       21)
    sensor = SensorParams(lost_per_min=0.0)
    bag = str(tmp_path / "run.bag")
    write_skeleton_bag(bag, SkeletonSource(script, sensor, 21), t0=100.0)
    assert recognize_main([bag]) == 0
    lines = capsys.readouterr().out.split()
    rows = [(float(lines[i]), lines[i + 1], float(lines[i + 2]))
            for i in range(0, len(lines), 3)]
    assert [r[1] for r in rows] == ["come_close", "go_away"]
    for (t, _command, err), e in zip(rows, [script[1], script[5]]):
        assert 100.0 + e.t0 < t <= 100.0 + e.motion_end + 0.5
        assert 0.0 <= err < GestureParams().threshold_rad2
    direct = GestureRecognizer([load_template(os.path.join(PKG, "templates", c + ".yaml"))
                                for c in ("come_close", "go_away")], GestureParams())
    src = SkeletonSource(script, sensor, 21)
    got = []
    for t in np.arange(0.0, src.end_s, 1.0 / 30.0):
        f = src.frame(float(t))
        m = f and direct.on_frame(f.t, f.user, f.joints).match
        if m:
            got.append((m.command, round(m.error_rad2, 4)))
    assert got == [(r[1], r[2]) for r in rows]


def test_recognize_gestures_bad_input(tmp_path, capsys):
    assert recognize_main(["/nonexistent.bag"]) == 2
    assert "cannot read /nonexistent.bag" in capsys.readouterr().err
    bag = str(tmp_path / "empty.bag")
    with Writer(bag) as w:
        w.add_connection("/tf", "tf2_msgs/msg/TFMessage", msgdef=TFMessage._full_text,
                         md5sum=TFMessage._md5sum)
    assert recognize_main([bag]) == 2
    assert "no skeleton frames" in capsys.readouterr().err
    bad = tmp_path / "bad.yaml"
    bad.write_text("command: come_close\n")
    assert recognize_main([bag, "--come-close-template", str(bad)]) == 3
    assert "lacks rate_hz" in capsys.readouterr().err
