"""``navd sensor KIND --port DEV``: a sensor program, reading a device and streaming to navd.

Each runs as a process of its own (a crash in one never takes the daemon down), started by
hand or by a systemd unit per device.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import re
import sys

from navd.cli.common import EXIT_OK, EXIT_USAGE, Commands
from navd.logs import configure_logging

__all__ = ["add_commands"]

KIND_NAMES = ("rplidar", "rplidar-express", "ld06", "ld19", "stl19p", "nmea")


def add_commands(commands: Commands) -> None:
    """Add ``sensor``."""
    sensor = commands.add_parser(
        "sensor",
        help=(
            "read a device (RPLIDAR, LD06/LD19/STL-19P lidar, NMEA GNSS receiver) and stream "
            "it to navd"
        ),
    )
    sensor.add_argument(
        "kind",
        choices=KIND_NAMES,
        help="what the device is (rplidar-express: an RPLIDAR in its express scan)",
    )
    sensor.add_argument("--port", required=True, help="its serial port, e.g. /dev/ttyUSB0")
    sensor.add_argument("--baud", type=int, help="serial rate (default: the kind's usual one)")
    sensor.add_argument(
        "--device-id", help="the name navd knows it by (default: KIND-PORTNAME, e.g. ld06-ttyUSB0)"
    )
    sensor.add_argument(
        "--navd", default="127.0.0.1:7420", help="where navd listens, HOST:PORT (127.0.0.1:7420)"
    )
    sensor.add_argument("--token", help="navd's tcp.token (default: $NAVD_TOKEN)")
    sensor.add_argument(
        "--log-level", default="info", choices=("debug", "info", "warning", "error")
    )
    sensor.set_defaults(handler=_sensor)


def _sensor(args: argparse.Namespace) -> int:
    from navd.drivers.protocol.frames import DEVICE_ID_PATTERN  # noqa: PLC0415
    from navd.sensors.runner import KINDS, Link, run_sensor  # noqa: PLC0415 - pyserial etc.

    host, _, port_text = args.navd.rpartition(":")
    if not host or not port_text.isdigit():
        print(f"navd sensor: --navd {args.navd!r} is not HOST:PORT", file=sys.stderr)
        return EXIT_USAGE
    device_id = args.device_id or f"{args.kind}-{os.path.basename(args.port)}"
    if not re.match(DEVICE_ID_PATTERN, device_id):
        print(
            f"navd sensor: device id {device_id!r} must be 1-64 letters, digits, _ . : -",
            file=sys.stderr,
        )
        return EXIT_USAGE
    configure_logging(args.log_level, "auto")
    link = Link(
        port=args.port,
        baud=args.baud or KINDS[args.kind].baud,
        host=host,
        navd_port=int(port_text),
        device_id=device_id,
        token=args.token or os.environ.get("NAVD_TOKEN"),
    )
    with contextlib.suppress(KeyboardInterrupt):  # Ctrl-C: the program ends, ports closed
        run_sensor(args.kind, link)
    return EXIT_OK
