"""The package's command-line tools (no rospy): ``record_gesture_template`` and
``recognize_gestures``.

    recognize_gestures RUN.bag [--come-close-template F] [--go-away-template F]
        [--threshold-rad2 T] [--depth-frame openni_depth_frame]

reads the skeleton frames of a bag's ``/tf`` (openni_tracker's, or skeleton_sim's) and
prints one line per recognized gesture, in order: its time (the stamp of the frame that
matched, seconds), command and match error [rad^2], e.g. ``1795453329.912 come_close
0.0380``; nothing when none. The frames go through the gesture_recognizer node's code
(SkeletonFrames, GestureRecognizer) with its default parameters and the package's
templates unless given. Exit status 0; 2 if the bag cannot be read or has no skeleton
frames; 3 if a template is missing or malformed (named on stderr).

    record_gesture_template COMMAND -o FILE.yaml --sim [--seed N]
    record_gesture_template COMMAND -o FILE.yaml --bag RUN.bag --start S --end E
        [--depth-frame openni_depth_frame]

``--sim``: the simulated person (telepresence.skeleton_sim) performs COMMAND once with
the mean parameters and seed N's sensor noise; the cycles are cut out. ``--bag``: the
skeleton in a bag's ``/tf`` (openni_tracker recorded while someone performs COMMAND),
cut from S to E seconds after the bag's first message. Writes the template (YAML: the
right elbow's yaw and pitch at 15 Hz) and prints one line: samples, duration, source.
Exit status 0; 2 on bad input (no such bag, too few frames, the user changes), named on
stderr.
"""
from __future__ import annotations

import argparse
import os
import sys
from typing import Iterator, List, Tuple

from telepresence.gestures import (
    COMMANDS,
    BadSkeleton,
    GestureParams,
    GestureRecognizer,
    SkeletonFrames,
    TemplateError,
    elbow_angles,
    load_template,
    save_template,
)
from telepresence.recording import Sample, record_sim_template, template_from_samples


def bag_transforms(path: str) -> Iterator[Tuple[float, float, str, str, Tuple[float, ...]]]:
    """(receive time [s], stamp [s], parent, child, xyz) of every transform on ``/tf``
    of the ROS 1 bag ``path``, in the bag's order."""
    from rosbags.rosbag1 import Reader
    from tf2_msgs.msg import TFMessage
    with Reader(path) as reader:
        conns = [c for c in reader.connections if c.topic in ("/tf", "tf")]
        for _conn, t_ns, raw in reader.messages(connections=conns):
            for tr in TFMessage().deserialize(raw).transforms:
                p = tr.transform.translation
                yield (t_ns * 1e-9, tr.header.stamp.to_sec(), tr.header.frame_id,
                       tr.child_frame_id, (p.x, p.y, p.z))


def bag_frames(path: str, depth_frame: str = "openni_depth_frame", max_skew_s: float = 0.05
               ) -> Iterator[Tuple[float, int, dict]]:
    """The skeleton frames (t [s], user, joints) of a bag's ``/tf``, assembled as the
    gesture_recognizer node assembles them (telepresence.gestures.SkeletonFrames)."""
    frames = SkeletonFrames(depth_frame, max_skew_s)
    for _received, stamp, parent, child, xyz in bag_transforms(path):
        yield from frames.take(stamp)  # frames completed before this transform
        frames.add(parent, child, stamp, xyz)
    yield from frames.take(float("inf"))


def bag_samples(path: str, depth_frame: str) -> List[Sample]:
    out = []
    for t, user, joints in bag_frames(path, depth_frame):
        try:
            yaw, pitch = elbow_angles(joints)
        except BadSkeleton:
            continue
        out.append((t, user, yaw, pitch))
    return out


def record_main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="record_gesture_template",
                                 description="Record a gesture template (thesis 4.4).")
    ap.add_argument("command", choices=COMMANDS)
    ap.add_argument("-o", "--output", required=True, help="template file to write (YAML)")
    src = ap.add_mutually_exclusive_group(required=True)
    src.add_argument("--sim", action="store_true", help="the simulated person performs it")
    src.add_argument("--bag", help="a bag with openni_tracker's /tf")
    ap.add_argument("--seed", type=int, default=1, help="--sim: the sensor noise's seed")
    ap.add_argument("--start", type=float, help="--bag: start [s after the bag's start]")
    ap.add_argument("--end", type=float, help="--bag: end [s after the bag's start]")
    ap.add_argument("--depth-frame", default="openni_depth_frame")
    a = ap.parse_args(argv)
    try:
        if a.sim:
            tp = record_sim_template(a.command, a.seed)
        else:
            if a.start is None or a.end is None or a.end <= a.start:
                ap.error("--bag needs --start and --end (end > start)")
            samples = bag_samples(a.bag, a.depth_frame)
            if not samples:
                raise ValueError("no usable skeleton frames of %s in %s"
                                 % (a.depth_frame, a.bag))
            t0 = samples[0][0]
            tp = template_from_samples(a.command, samples, t0 + a.start, t0 + a.end,
                                       source="bag %s, %.2f-%.2f s" % (a.bag, a.start, a.end))
    except (OSError, ValueError) as err:
        print("record_gesture_template: %s" % err, file=sys.stderr)
        return 2
    except Exception as err:  # noqa: BLE001 -- rosbags' own errors (not a bag, truncated)
        if not _bag_error(err):
            raise
        print("record_gesture_template: %s: %s" % (a.bag, err), file=sys.stderr)
        return 2
    save_template(a.output, tp)
    print("%s: %s, %d samples, %.2f s, %s" % (a.output, tp.command, len(tp.yaw),
                                              tp.duration_s, tp.source))
    return 0


def _bag_error(err: Exception) -> bool:
    """Whether ``err`` is one of reading a bag (rosbags' own errors, or the file's)."""
    return isinstance(err, OSError) or type(err).__module__.startswith("rosbags")


def recognize_main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="recognize_gestures",
                                 description="Gestures in a bag's skeleton TF frames.")
    ap.add_argument("bag")
    pkg = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    for c in COMMANDS:
        ap.add_argument("--%s-template" % c.replace("_", "-"),
                        default=os.path.join(pkg, "templates", c + ".yaml"))
    ap.add_argument("--threshold-rad2", type=float, default=GestureParams().threshold_rad2)
    ap.add_argument("--depth-frame", default="openni_depth_frame")
    a = ap.parse_args(argv)
    try:
        templates = [load_template(getattr(a, "%s_template" % c)) for c in COMMANDS]
    except TemplateError as err:
        print("recognize_gestures: %s" % err, file=sys.stderr)
        return 3
    rec = GestureRecognizer(templates, GestureParams(threshold_rad2=a.threshold_rad2))
    frames = 0
    try:
        for t, user, joints in bag_frames(a.bag, a.depth_frame):
            frames += 1
            m = rec.on_frame(t, user, joints).match
            if m is not None:
                print("%.3f %s %.4f" % (m.t, m.command, m.error_rad2), flush=True)
    except Exception as err:  # noqa: BLE001 -- only bag errors are handled, others re-raised
        if not _bag_error(err):
            raise
        print("recognize_gestures: cannot read %s: %s" % (a.bag, err), file=sys.stderr)
        return 2
    if frames == 0:
        print("recognize_gestures: no skeleton frames (children of %s on /tf) in %s"
              % (a.depth_frame, a.bag), file=sys.stderr)
        return 2
    return 0
