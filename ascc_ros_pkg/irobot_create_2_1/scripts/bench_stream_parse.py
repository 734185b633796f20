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


def bench(robot, frames, repeats):
    """Microseconds per frame: the median and the best of ``repeats`` passes."""
    per_frame = []
    for _ in range(repeats):
        core = CreateDriverCore(robot=robot)
        t = 0.0
        t0 = time.perf_counter()
        for frame in frames:
            t += oi.STREAM_PERIOD_S
            core.on_bytes(frame, t)
        per_frame.append((time.perf_counter() - t0) / len(frames) * 1e6)
        assert core.parser.frames_ok == len(frames) and not core.mismatch
    return statistics.median(per_frame), min(per_frame)


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
    ap.add_argument("--repeats", type=int, default=7)
    args = ap.parse_args()
    print("machine: %s, Python %s" % (cpu_name(), platform.python_version()))
    results = {}
    for name, robot in sorted(MODELS.items()):
        frames = record(robot, args.frames)
        median, best = bench(robot, frames, args.repeats)
        results[name] = median
        print("%s: %d-byte frames (Stream %s), %d frames x %d passes: %.1f us/frame "
              "median, %.1f best; %.2f %% of the 15 ms period"
              % (name, len(frames[0]), list(robot.stream_packets), len(frames),
                 args.repeats, median, best, median / (oi.STREAM_PERIOD_S * 1e6) * 100))
    print("create_2 / create_1: %.2fx" % (results["create_2"] / results["create_1"]))


if __name__ == "__main__":
    main()
