"""Serial devices as their makers describe them: the bytes of an LD06, an RPLIDAR and an
NMEA receiver, on a pseudo-terminal, at the device's baud rate and rhythm. Written from the
makers' protocol documents, not from navd's drivers, and each checked against an independent
host library in the tests (lds2d, rplidar, pyrplidar, pynmea2)."""

from navd.sim.devices.ld06_device import Ld06Device
from navd.sim.devices.nmea_device import GnssState, NmeaDevice
from navd.sim.devices.rplidar_device import MODELS, RplidarDevice
from navd.sim.devices.serial_line import SerialLine, UartWriter

__all__ = [
    "MODELS",
    "GnssState",
    "Ld06Device",
    "NmeaDevice",
    "RplidarDevice",
    "SerialLine",
    "UartWriter",
]
