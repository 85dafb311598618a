"""Drivers: the TCP peripheral server (sensor and control clients) and the STM32 chassis.

The serial port and the wheel kinematics load with the face; the two daemon modules
(``ChassisDriver``, ``TcpServer``) and the conversion of sensor frames only when asked for.
"""

from typing import TYPE_CHECKING

from navd.drivers.errors import DriverError, SerialPortError
from navd.drivers.kinematics import WheelCalibration, body_velocity, wheel_command, wheel_speeds
from navd.drivers.serial_port import open_exclusive
from navd.lazy_face import lazy_members

if TYPE_CHECKING:
    from navd.drivers.chassis import ChassisDriver
    from navd.drivers.convert import sensor_message
    from navd.drivers.tcp.server import TcpServer

__getattr__ = lazy_members(
    __name__,
    {"ChassisDriver": "chassis", "TcpServer": "tcp.server", "sensor_message": "convert"},
)

__all__ = [
    "ChassisDriver",
    "DriverError",
    "SerialPortError",
    "TcpServer",
    "WheelCalibration",
    "body_velocity",
    "open_exclusive",
    "sensor_message",
    "wheel_command",
    "wheel_speeds",
]
