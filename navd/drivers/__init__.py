"""Drivers: the TCP peripheral server (sensor and control clients) and the STM32 chassis."""

from navd.drivers.chassis import ChassisDriver
from navd.drivers.convert import control_message, sensor_message
from navd.drivers.errors import DriverError, SerialPortError
from navd.drivers.kinematics import WheelCalibration, body_velocity, wheel_command, wheel_speeds
from navd.drivers.serial_port import open_exclusive

__all__ = [
    "ChassisDriver",
    "DriverError",
    "SerialPortError",
    "WheelCalibration",
    "body_velocity",
    "control_message",
    "open_exclusive",
    "sensor_message",
    "wheel_command",
    "wheel_speeds",
]
