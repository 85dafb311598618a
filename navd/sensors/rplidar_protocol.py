"""Slamtec RPLIDAR A1/A2/A3/C1/S1: the serial protocol's requests and answers.

Written from Slamtec's "RPLIDAR Interface Protocol and Application Notes". A request is
``0xA5 cmd`` with, for commands that take one, a payload size, the payload and an XOR
checksum of every byte before it. An answer starts with a 7-byte descriptor: ``0xA5 0x5A``,
a 30-bit length and 2-bit send mode (little-endian), and a data type.

============== ===== ==========================================================
request        cmd   answer
============== ===== ==========================================================
STOP           0x25  none; the lidar stops sending (wait 1 ms before the next request)
RESET          0x40  none; the core restarts and prints a text banner
GET_HEALTH     0x52  type 0x06, 3 bytes: status (0 good, 1 warning, 2 error), error u16
GET_INFO       0x50  type 0x04, 20 bytes: model, firmware minor, major, hardware, serial[16]
GET_LIDAR_CONF 0x84  type 0x20: the u32 asked for, then its value (firmware 1.24 and later)
SCAN           0x20  type 0x81, then 5-byte samples until STOP (the standard scan)
EXPRESS_SCAN   0x82  type 0x82 (express), 0x84 (ultra) or 0x85 (dense), then 84-byte
                     capsules until STOP; payload: the scan mode's id, four zero bytes
MOTOR_PWM      0xF0  none; the A2/A3 motor duty (0-1023; 0 stops it)
============== ===== ==========================================================

GET_LIDAR_CONF asks, by a u32 key, for the number of scan modes (0x70, u16), the typical
mode (0x7C, u16), and per mode (key then u16 mode id): its name (0x7F, text), its longest
range (0x74, u32 in 1/256 m), its time per sample (0x71, u32 in 1/256 µs) and the answer
type its samples come in (0x75, u8).
"""

from __future__ import annotations

import enum
import struct
from dataclasses import dataclass

__all__ = [
    "ANSWER",
    "CAPSULE_BYTES",
    "DESCRIPTOR_BYTES",
    "SAMPLE_BYTES",
    "SYNC",
    "Answer",
    "Command",
    "Conf",
    "RplidarInfo",
    "ScanModeInfo",
    "conf_request",
    "request",
    "series_range_max_m",
]

SYNC = 0xA5
ANSWER = 0x5A
DESCRIPTOR_BYTES = 7
SAMPLE_BYTES = 5
CAPSULE_BYTES = 84

# [m] the longest range by series, for a lidar whose firmware cannot say (before 1.24)
_SERIES_RANGE_M = {"A1": 12.0, "A2": 12.0, "A3": 25.0, "C1": 12.0, "S1": 40.0, "S2": 30.0}
_SERIES = {1: "A1", 2: "A2", 3: "A3", 4: "C1", 6: "S1", 7: "S2"}


class Command(enum.IntEnum):
    """Request bytes (see the module docstring)."""

    STOP = 0x25
    RESET = 0x40
    SCAN = 0x20
    EXPRESS_SCAN = 0x82
    GET_INFO = 0x50
    GET_HEALTH = 0x52
    GET_LIDAR_CONF = 0x84
    SET_MOTOR_PWM = 0xF0


class Answer(enum.IntEnum):
    """Descriptor data types."""

    INFO = 0x04
    HEALTH = 0x06
    LIDAR_CONF = 0x20
    SCAN = 0x81
    EXPRESS = 0x82
    HQ = 0x83
    ULTRA = 0x84
    DENSE = 0x85


class Conf(enum.IntEnum):
    """GET_LIDAR_CONF keys."""

    MODE_COUNT = 0x70
    US_PER_SAMPLE = 0x71
    MAX_DISTANCE = 0x74
    ANSWER_TYPE = 0x75
    TYPICAL_MODE = 0x7C
    MODE_NAME = 0x7F


# the answer types navd reads; ultra capsules (0x84) and HQ nodes (0x83) it does not
READABLE = (Answer.SCAN, Answer.EXPRESS, Answer.DENSE)


def request(command: Command, payload: bytes | None = None) -> bytes:
    """The bytes of a request, with its size and checksum when it has a payload."""
    if payload is None:
        return bytes([SYNC, command])
    body = bytes([SYNC, command, len(payload)]) + payload
    checksum = 0
    for byte in body:
        checksum ^= byte
    return body + bytes([checksum])


def conf_request(key: Conf, mode: int | None = None) -> bytes:
    """GET_LIDAR_CONF for ``key`` (of scan mode ``mode`` when the key is per mode)."""
    payload = struct.pack("<I", key) + (b"" if mode is None else struct.pack("<H", mode))
    return request(Command.GET_LIDAR_CONF, payload)


@dataclass(frozen=True, slots=True)
class RplidarInfo:
    """What GET_INFO says: the model byte, firmware and hardware versions, serial number."""

    model: int
    firmware: str
    hardware: int
    serial: str

    @property
    def series(self) -> str:
        """ "A1", "A2", "A3", "C1", "S1", "S2" by the model byte's high nibble; else the
        byte itself."""
        return _SERIES.get(self.model >> 4, f"model 0x{self.model:02X}")

    @property
    def spins_by_pwm(self) -> bool:
        """The A2 and A3 take a motor duty; the A1 spins on DTR, the C and S series alone."""
        return self.series in ("A2", "A3")


def series_range_max_m(info: RplidarInfo | None) -> float:
    """[m] the longest range of the lidar's series when its firmware does not say (12 m for
    a series not known)."""
    return _SERIES_RANGE_M.get(info.series if info else "", 12.0)


@dataclass(frozen=True, slots=True)
class ScanModeInfo:
    """One scan mode as GET_LIDAR_CONF describes it.

    Attributes:
        mode_id: what EXPRESS_SCAN is asked with.
        name: the maker's name ("Standard", "Express", "Boost", "DenseBoost", ...).
        max_distance_m: [m] its longest range.
        us_per_sample: [µs] time between two samples.
        answer: the data type its samples come in.
    """

    mode_id: int
    name: str
    max_distance_m: float
    us_per_sample: float
    answer: int

    @property
    def readable(self) -> bool:
        """Whether navd decodes its samples."""
        return self.answer in READABLE
