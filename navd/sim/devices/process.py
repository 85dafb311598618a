"""A device emulator as a process of its own, so a benchmark's lidar never shares the
measuring process's interpreter: ``python -m navd.sim.devices.process KIND``.

It opens a pseudo-terminal and prints ``{"tty": PATH}`` (the end a sensor program opens),
then takes commands on its standard input, one a line: ``go`` starts the device, ``freeze``
hangs it (it sends nothing, hears nothing), ``thaw`` brings it back, ``stop`` ends the run
(as does ``--seconds`` passing after ``go``, or standard input closing). At the end it
prints ``{"sent": TURNS, "turns": [[FIRST_S, LAST_S], ...]}`` (each turn's first and last
sample on this computer's monotonic clock) and holds the terminal open until its standard
input closes.

The room: a rectangle 8 m by 5 m with the lidar 1.5 m and 1 m off its centre.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import threading

from navd.sim.devices.ld06_device import Ld06Device
from navd.sim.devices.rplidar_device import MODELS, RplidarDevice
from navd.sim.devices.serial_line import SerialLine

__all__ = ["main", "room"]

HALF_X_M, HALF_Y_M = 4.0, 2.5
LIDAR_X_M, LIDAR_Y_M = 1.5, 1.0


def room(angle_cw_deg: float) -> tuple[float, int]:
    """[m] the range to the rectangle's walls at a clockwise angle, and an intensity."""
    a = -math.radians(angle_cw_deg)
    c, s = math.cos(a), math.sin(a)
    ranges = []
    if c > 1e-9:
        ranges.append((HALF_X_M - LIDAR_X_M) / c)
    if c < -1e-9:
        ranges.append((-HALF_X_M - LIDAR_X_M) / c)
    if s > 1e-9:
        ranges.append((HALF_Y_M - LIDAR_Y_M) / s)
    if s < -1e-9:
        ranges.append((-HALF_Y_M - LIDAR_Y_M) / s)
    return min(ranges), 150


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("kind", choices=("ld06", "rplidar"))
    parser.add_argument("--model", default="A1", choices=sorted(MODELS), help="an RPLIDAR's")
    parser.add_argument("--points", type=int, default=450, help="an LD06's points per turn")
    parser.add_argument("--seconds", type=float, default=math.inf, help="stop after this")
    args = parser.parse_args()
    line = SerialLine()
    device: Ld06Device | RplidarDevice
    if args.kind == "ld06":
        device = Ld06Device(room, sample_hz=args.points * 10.0)
        serve = device.stream
    else:
        device = RplidarDevice(room, model=args.model)
        serve = device.serve
    print(json.dumps({"tty": str(line.path)}), flush=True)
    stop = threading.Event()
    started = threading.Event()
    threading.Thread(target=_commands, args=(device, started, stop), daemon=True).start()
    started.wait()
    thread = threading.Thread(target=serve, args=(line, stop), daemon=True)
    thread.start()
    stop.wait(None if math.isinf(args.seconds) else args.seconds)
    stop.set()
    thread.join(5.0)
    turns = [[t.first_s, t.last_s] for t in device.turns]
    print(json.dumps({"sent": len(turns), "turns": turns}), flush=True)
    sys.stdin.read()
    line.close()


def _commands(
    device: Ld06Device | RplidarDevice, started: threading.Event, stop: threading.Event
) -> None:
    """Standard input's commands, until it closes (which stops the run too)."""
    for command in sys.stdin:
        word = command.strip()
        if word == "go":
            started.set()
        elif word == "freeze":
            device.frozen.set()
        elif word == "thaw":
            device.frozen.clear()
        elif word == "stop":
            started.set()
            stop.set()
            return
    started.set()
    stop.set()


if __name__ == "__main__":
    main()
