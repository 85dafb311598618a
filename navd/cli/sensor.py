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
from pathlib import Path
from typing import TYPE_CHECKING

from navd.cli.common import EXIT_FAILED, EXIT_OK, EXIT_USAGE, Commands
from navd.logs import configure_logging

if TYPE_CHECKING:
    from navd.sensors import Link

__all__ = ["add_commands"]

SERIAL_KINDS = ("rplidar", "rplidar-express", "ld06", "ld19", "stl19p", "nmea", "mcu", "tfmini")
I2C_KINDS = ("mpu6050", "mpu9250", "bno055", "qmc5883l", "hmc5883l", "ina219")
KIND_NAMES = (*SERIAL_KINDS, *I2C_KINDS, "calibrate-compass")
DEFAULT_CONFIG = "/etc/navd/navd.toml"


def add_commands(commands: Commands) -> None:
    """Add ``sensor``."""
    sensor = commands.add_parser(
        "sensor",
        help=(
            "read a device (RPLIDAR, LD06/LD19/STL-19P lidar, NMEA GNSS receiver, I2C IMU or "
            "magnetometer) and stream it to navd; or calibrate a magnetometer"
        ),
    )
    sensor.add_argument(
        "kind",
        choices=KIND_NAMES,
        help=(
            "what the device is (rplidar-express: an RPLIDAR in its express scan); "
            "calibrate-compass records a turn in place and writes the correction"
        ),
    )
    sensor.add_argument(
        "--port",
        required=True,
        help="its serial port (/dev/ttyUSB0) or, for an I2C chip, its bus (/dev/i2c-1 or 1)",
    )
    sensor.add_argument("--address", help="an I2C chip's address, e.g. 0x69 (default: its usual)")
    sensor.add_argument("--rate", type=float, help="[Hz] how often an I2C chip is read")
    sensor.add_argument(
        "--shunt-ohms", type=float, default=0.1, help="ina219: [ohm] the shunt resistor (0.1)"
    )
    sensor.add_argument(
        "--cells", type=int, default=3, help="ina219: the battery's cells in series (3)"
    )
    sensor.add_argument(
        "--chemistry",
        default="li-ion",
        choices=("li-ion", "lifepo4", "lead-acid"),
        help="ina219: the battery's chemistry (li-ion)",
    )
    sensor.add_argument(
        "--current-sign",
        type=int,
        default=1,
        choices=(1, -1),
        help="ina219: -1 when the chip is wired the other way round (current reads backwards)",
    )
    sensor.add_argument(
        "--chip",
        choices=("qmc5883l", "hmc5883l"),
        help="calibrate-compass: which magnetometer",
    )
    sensor.add_argument(
        "--seconds", type=float, default=40.0, help="calibrate-compass: how long to record (40)"
    )
    sensor.add_argument(
        "--config",
        help=(
            "navd's config file: a magnetometer's calibration is read from (and written to) "
            f"[mounts.compasses.ID] there (default: $NAVD_CONFIG, else {DEFAULT_CONFIG})"
        ),
    )
    sensor.add_argument("--baud", type=int, help="serial rate (default: the kind's usual one)")
    sensor.add_argument(
        "--scan-mode",
        help="rplidar: the scan mode by name, e.g. Standard, Express, DenseBoost (default: the "
        "lidar's typical mode, if navd reads it, else its fastest one navd reads)",
    )
    sensor.add_argument(
        "--range-max",
        type=float,
        help="[m] a lidar's longest trusted range (default: what the lidar says, else its model's)",
    )
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
    from navd.sensors import KINDS, Link  # noqa: PLC0415 - pyserial etc.
    from navd.wire import DEVICE_ID_PATTERN  # noqa: PLC0415

    host, _, port_text = args.navd.rpartition(":")
    if not host or not port_text.isdigit():
        print(f"navd sensor: --navd {args.navd!r} is not HOST:PORT", file=sys.stderr)
        return EXIT_USAGE
    i2c = args.kind in I2C_KINDS or args.kind == "calibrate-compass"
    port = f"/dev/i2c-{args.port}" if i2c and args.port.isdigit() else args.port
    named = args.chip if args.kind == "calibrate-compass" and args.chip else args.kind
    device_id = args.device_id or f"{named}-{os.path.basename(port)}"
    if not re.match(DEVICE_ID_PATTERN, device_id):
        print(
            f"navd sensor: device id {device_id!r} must be 1-64 letters, digits, _ . : -",
            file=sys.stderr,
        )
        return EXIT_USAGE
    if args.range_max is not None and not 0.1 <= args.range_max <= 100.0:
        print(f"navd sensor: --range-max {args.range_max} must be 0.1 to 100 m", file=sys.stderr)
        return EXIT_USAGE
    try:
        address = None if args.address is None else int(args.address, 0)
    except ValueError:
        print(f"navd sensor: --address {args.address!r} is not a number", file=sys.stderr)
        return EXIT_USAGE
    configure_logging(args.log_level, "auto")
    link = Link(
        port=port,
        baud=args.baud or (KINDS[args.kind].baud if args.kind in KINDS else 0),
        host=host,
        navd_port=int(port_text),
        device_id=device_id,
        token=args.token or os.environ.get("NAVD_TOKEN"),
        scan_mode=args.scan_mode,
        range_max_m=args.range_max,
    )
    if args.kind == "calibrate-compass":
        return _calibrate(args, link, address)
    if i2c:
        return _run_i2c(args, link, address)
    from navd.sensors import run_sensor  # noqa: PLC0415

    with contextlib.suppress(KeyboardInterrupt):  # Ctrl-C: the program ends, ports closed
        run_sensor(args.kind, link)
    return EXIT_OK


def _config_path(args: argparse.Namespace) -> Path:
    return Path(args.config or os.environ.get("NAVD_CONFIG") or DEFAULT_CONFIG)


def _run_i2c(args: argparse.Namespace, link: Link, address: int | None) -> int:
    """Stream an I2C chip; a magnetometer through its calibration in navd's config."""
    from navd.config import ConfigError, load_config  # noqa: PLC0415
    from navd.sensors import (  # noqa: PLC0415
        CompassCalibration,
        I2cOptions,
        run_i2c_sensor,
    )

    calibration = None
    path = _config_path(args)
    if args.kind in ("qmc5883l", "hmc5883l") and (path.exists() or args.config is not None):
        try:
            mount = load_config(path).mounts.compasses.get(link.device_id)
        except ConfigError as err:
            print(f"navd sensor: {err}", file=sys.stderr)
            return EXIT_USAGE
        if mount is not None:
            calibration = CompassCalibration(mount.hard_iron_ut, mount.soft_iron)
    if args.shunt_ohms <= 0 or not 1 <= args.cells <= 48:
        print("navd sensor: --shunt-ohms must be > 0 and --cells 1 to 48", file=sys.stderr)
        return EXIT_USAGE
    battery = (args.shunt_ohms, args.cells, args.chemistry, args.current_sign)
    with contextlib.suppress(KeyboardInterrupt):
        run_i2c_sensor(args.kind, link, I2cOptions(address, args.rate, calibration, battery))
    return EXIT_OK


def _calibrate(args: argparse.Namespace, link: Link, address: int | None) -> int:
    """Record the raw field while the robot turns in place; write the fitted correction."""
    from navd.config import (  # noqa: PLC0415
        ConfigError,
        set_table_keys,
        toml_key,
    )
    from navd.sensors import (  # noqa: PLC0415
        ChipError,
        I2cOptions,
        record_turn,
    )

    if args.chip is None:
        print("navd sensor calibrate-compass: say which magnetometer: --chip", file=sys.stderr)
        return EXIT_USAGE
    print(
        f"Turn the robot slowly in place, one full turn or more, within {args.seconds:g} s "
        "(level, away from steel)...",
        flush=True,
    )
    options = I2cOptions(address, args.rate)
    try:
        fit, samples = record_turn(args.chip, link.port, options, args.seconds)
    except (OSError, ChipError, ValueError) as err:
        print(f"navd sensor calibrate-compass: {err}", file=sys.stderr)
        return EXIT_FAILED
    path = _config_path(args)
    table = f"mounts.compasses.{toml_key(link.device_id)}"
    values = {
        "hard_iron_ut": list(fit.hard_iron_ut),
        "soft_iron": [list(row) for row in fit.soft_iron],
    }
    try:
        set_table_keys(path, table, values)
    except (ConfigError, OSError) as err:
        print(f"navd sensor calibrate-compass: {err}", file=sys.stderr)
        return EXIT_FAILED
    x, y = fit.hard_iron_ut
    print(f"{samples} samples: hard iron ({x:.1f}, {y:.1f}) µT; written to [{table}] in {path}")
    return EXIT_OK
