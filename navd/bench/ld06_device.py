"""An emulated LDRobot LD06 for benchmarks: a pseudo-terminal that streams its packets.

Run as ``python -m navd.bench.ld06_device --seconds 10 --points 450``. It opens a
pseudo-terminal, prints ``{"tty": PATH}`` (the device end a sensor program opens), and when
a line arrives on its standard input streams ten turns a second of a room 3 m around, in
packets of 12 points as the lidar sends them, paced in real time. When done it prints
``{"sent": TURNS}`` and holds the terminal open until its standard input closes.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time

from navd.sensors import POINTS, encode_packet

TURN_HZ = 10.0


def turn_packets(points: int, turn: int) -> list[bytes]:
    """One turn of ``points`` points (rounded up to whole packets) of a 3 m room."""
    packets = math.ceil(points / POINTS)
    span = 360.0 / packets
    return [
        encode_packet(
            TURN_HZ * 360.0,
            k * span,
            k * span + span * (POINTS - 1) / POINTS,
            [3.0 + 0.001 * ((turn + k) % 7)] * POINTS,
            (turn * packets + k) * 2,
        )
        for k in range(packets)
    ]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=10.0)
    parser.add_argument("--points", type=int, default=450, help="points per turn")
    args = parser.parse_args()
    master, slave = os.openpty()
    print(json.dumps({"tty": os.ttyname(slave)}), flush=True)
    sys.stdin.readline()
    start = time.monotonic()
    turns = round(args.seconds * TURN_HZ)
    for turn in range(turns):
        packets = turn_packets(args.points, turn)
        for k, packet in enumerate(packets):  # spread over the turn, as the lidar does
            due = start + (turn + k / len(packets)) / TURN_HZ
            time.sleep(max(due - time.monotonic(), 0.0))
            os.write(master, packet)
    os.write(master, turn_packets(args.points, turns)[0])  # ends the last turn
    time.sleep(0.5)  # for the sensor program to read and send it
    print(json.dumps({"sent": turns}), flush=True)
    sys.stdin.read()
    os.close(master)
    os.close(slave)


if __name__ == "__main__":
    main()
