"""Benchmark of the virtual Create: how fast it emulates, parses and answers over a pty.

Run: python ascc_ros_pkg/irobot_create_2_1/scripts/bench_virtual_create.py  (after
`source env.sh`). Prints one line per measurement; numbers go in
docs/results/irobot_create_2_1.md.
"""
import argparse
import statistics
import time

import serial

from irobot_create_2_1 import protocol as oi
from irobot_create_2_1.pty_link import PtyLink
from irobot_create_2_1.virtual_create import VirtualCreate


def bench_step(emulated_s: float, dt_s: float) -> None:
    """Emulated seconds per wall second: 200 Hz steps, driving an arc, streaming group 6."""
    create = VirtualCreate()
    create.feed(oi.start() + oi.full() + oi.stream([6]) + oi.drive(300, 700))
    steps = int(round(emulated_s / dt_s))
    t0 = time.perf_counter()
    for _ in range(steps):
        create.step(dt_s)
        create.read_output()
    wall = time.perf_counter() - t0
    print("step: %d steps of %.1f ms + %d group-6 frames in %.3f s wall -> %.0fx real time, "
          "%.1f us/step" % (steps, dt_s * 1e3, create.frames_sent, wall, emulated_s / wall,
                            wall / steps * 1e6))


def bench_commands(n: int) -> None:
    """Host commands per second: Drive Direct + Sensors(6) pairs fed as one byte string."""
    create = VirtualCreate()
    create.feed(oi.start() + oi.full())
    chunk = oi.drive_direct(100, -100) + oi.sensors(6)
    data = chunk * n
    t0 = time.perf_counter()
    for i in range(0, len(data), 4096):
        create.feed(data[i:i + 4096])
        create.read_output()
    wall = time.perf_counter() - t0
    print("commands: %d Drive Direct + %d Sensors(6) in %.3f s -> %.0f commands/s"
          % (n, n, wall, 2 * n / wall))


def bench_pty_round_trip(n: int) -> None:
    """Sensors(35) request -> 1-byte reply through the pty and pyserial, pumped inline."""
    create = VirtualCreate()
    create.feed(oi.start())
    with PtyLink(create) as link, serial.Serial(link.port, 57600, timeout=0) as port:
        times = []
        for _ in range(n):
            t0 = time.perf_counter()
            port.write(oi.sensors(35))
            got = b""
            while not got:
                link.pump()
                got = port.read(1)
            times.append(time.perf_counter() - t0)
    times.sort()
    print("pty round trip (write, pump, read 1 byte): median %.1f us, p95 %.1f us over %d"
          % (statistics.median(times) * 1e6, times[int(0.95 * n)] * 1e6, n))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--emulated-s", type=float, default=60.0,
                        help="emulated time for the step benchmark [s]")
    parser.add_argument("--commands", type=int, default=20000)
    parser.add_argument("--round-trips", type=int, default=2000)
    args = parser.parse_args()
    bench_step(args.emulated_s, 0.005)
    bench_commands(args.commands)
    bench_pty_round_trip(args.round_trips)


if __name__ == "__main__":
    main()
