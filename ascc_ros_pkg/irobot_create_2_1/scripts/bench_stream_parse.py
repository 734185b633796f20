"""Benchmark: the driver's cost per stream frame, Create 2 (group 100, 84-byte frames,
encoder odometry) against Create 1 (group 6, 56-byte frames, distance/angle odometry).

The frames are recorded first from a virtual Create of each model driving an arc; then
the driver core (``CreateDriverCore.on_bytes``: framing, checksum, decoding, model check,
odometry, stamping) is fed them one frame per call, as a host keeping up with the 15 ms
stream reads them. Prints one line per model; numbers go in
docs/results/irobot_create_2_1.md with the machine.

Run: python ascc_ros_pkg/irobot_create_2_1/scripts/bench_stream_parse.py  (after
`source env.sh`).
"""
import argparse
import platform
import statistics
import time

from irobot_create_2_1 import protocol as oi
from irobot_create_2_1.driver_core import CreateDriverCore
from irobot_create_2_1.models import MODELS
from irobot_create_2_1.virtual_create import VirtualCreate


def record(robot, n_frames):
    """n_frames stream frames (bytes each) of a virtual Create driving an arc."""
    create = VirtualCreate(robot=robot)
    core = CreateDriverCore(robot=robot)
    create.feed(core.init_sequence() + oi.drive_direct(200, 300))
    frames = []
    frame_len = robot.stream_body_bytes + 3
    while len(frames) < n_frames:
        create.step(oi.STREAM_PERIOD_S)
        out = create.read_output()
        frames += [out[i:i + frame_len] for i in range(0, len(out), frame_len)]
    return frames[:n_frames]


def one_pass(robot, frames):
    """Microseconds per frame of one pass over ``frames``."""
    core = CreateDriverCore(robot=robot)
    t = 0.0
    t0 = time.perf_counter()
    for frame in frames:
        t += oi.STREAM_PERIOD_S
        core.on_bytes(frame, t)
    us = (time.perf_counter() - t0) / len(frames) * 1e6
    assert core.parser.frames_ok == len(frames) and not core.mismatch
    return us


def cpu_name():
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown CPU"


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=4000, help="frames per pass (60 s)")
    ap.add_argument("--repeats", type=int, default=15)
    args = ap.parse_args()
    print("machine: %s, Python %s" % (cpu_name(), platform.python_version()))
    models = sorted(MODELS.items())
    frames = {name: record(robot, args.frames) for name, robot in models}
    passes = {name: [] for name, _ in models}
    for _ in range(args.repeats):  # interleaved, so load changes hit both models alike
        for name, robot in models:
            passes[name].append(one_pass(robot, frames[name]))
    for name, robot in models:
        median, best = statistics.median(passes[name]), min(passes[name])
        print("%s: %d-byte frames (Stream %s), %d frames x %d passes: %.1f us/frame "
              "median, %.1f best; %.2f %% of the 15 ms period"
              % (name, len(frames[name][0]), list(robot.stream_packets), args.frames,
                 args.repeats, median, best, median / (oi.STREAM_PERIOD_S * 1e6) * 100))
    print("create_2 / create_1: %.2fx median, %.2fx best"
          % (statistics.median(passes["create_2"]) / statistics.median(passes["create_1"]),
             min(passes["create_2"]) / min(passes["create_1"])))

if __name__ == "__main__":
    main()
