"""Sensor programs (``navd sensor KIND``): read a device, stream to navd over TCP."""

from navd.sensors.calibration import record_turn
from navd.sensors.errors import CalibrationError, ChipError, SensorError
from navd.sensors.i2c_runner import I2cOptions, run_i2c_sensor
from navd.sensors.kinds import KINDS
from navd.sensors.ld06 import POINTS, encode_packet
from navd.sensors.link import Link
from navd.sensors.magnetometer import CompassCalibration
from navd.sensors.runner import run_sensor

__all__ = [
    "KINDS",
    "POINTS",
    "CalibrationError",
    "ChipError",
    "CompassCalibration",
    "I2cOptions",
    "Link",
    "SensorError",
    "encode_packet",
    "record_turn",
    "run_i2c_sensor",
    "run_sensor",
]
