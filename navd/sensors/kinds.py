"""The kinds of serial device a sensor program reads: each one's role in navd, its usual baud
rate, and the decoder that turns its bytes into navd's frames (asking the device what it must
be asked, for those that must)."""

from __future__ import annotations

import contextlib
from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

import serial

from navd.logs import get_logger
from navd.sensors.ld06 import RANGE_MAX_M, PacketReader, ScanAssembler
from navd.sensors.link import Link
from navd.sensors.mcu_lines import McuLines
from navd.sensors.nmea import NmeaReader
from navd.sensors.rplidar import RplidarDecoder
from navd.sensors.tfmini import RANGE_MAX_M as RANGE_MAX_TFMINI_M
from navd.sensors.tfmini import Tfmini
from navd.wire import Role, SensorFrame

__all__ = ["KINDS", "Decoder", "SensorKind"]


class Decoder(Protocol):
    """A device's bytes in, navd's frames out; a device that must be asked to send is asked
    when its port opens, and asked again when it falls silent."""

    def feed(self, data: bytes, stamp: float) -> list[SensorFrame]: ...

    def counts(self) -> dict[str, int]: ...

    def tick(self, now: float) -> None: ...

    def opened(self, device: serial.Serial) -> None: ...

    def silent(self) -> None: ...

    def closing(self, device: serial.Serial) -> None: ...


class _Streaming:
    """A device that streams by itself: nothing to ask."""

    def opened(self, device: serial.Serial) -> None:
        """Nothing to start."""

    def silent(self) -> None:
        """Nothing to ask again."""

    def closing(self, device: serial.Serial) -> None:
        """Nothing to stop."""

    def tick(self, now: float) -> None:
        """Nothing waits on the clock."""


def _set_dtr(device: serial.Serial) -> Callable[[bool], None]:
    def set_dtr(level: bool) -> None:
        # a pseudo-terminal or an adapter without modem lines has no DTR: nothing to do
        with contextlib.suppress(OSError, serial.SerialException):
            device.dtr = level

    return set_dtr


class _Rplidar:
    """A Slamtec RPLIDAR: asked for its health, info, modes and scan; one scan per turn."""

    def __init__(self, link: Link, mode: str | None) -> None:
        self.log = get_logger("sensor")
        self.lidar = RplidarDecoder(
            link.scan_mode or mode, baud=link.baud, range_max_m=link.range_max_m, notes=self._note
        )

    def _note(self, event: str, fields: dict[str, object]) -> None:
        quiet = ("lidar_info", "lidar_scan_mode", "lidar_reset_banner")
        level = self.log.info if event in quiet else self.log.warning
        level(event, **fields)

    def feed(self, data: bytes, stamp: float) -> list[SensorFrame]:
        return self.lidar.feed(data, stamp)

    def counts(self) -> dict[str, int]:
        return self.lidar.counts()

    def tick(self, now: float) -> None:
        self.lidar.tick(now)

    def opened(self, device: serial.Serial) -> None:
        self.lidar.opened(device.write, _set_dtr(device))

    def silent(self) -> None:
        self.lidar.restart()

    def closing(self, device: serial.Serial) -> None:
        with contextlib.suppress(OSError, serial.SerialException):
            self.lidar.closing(_set_dtr(device))


class _Ld06(_Streaming):
    """LD06 packets, one scan per turn."""

    def __init__(self, link: Link) -> None:
        self.reader = PacketReader()
        self.turns = ScanAssembler(range_max_m=link.range_max_m or RANGE_MAX_M)

    def feed(self, data: bytes, stamp: float) -> list[SensorFrame]:
        return list(self.turns.add_many(self.reader.feed_timed(data, stamp)))

    def counts(self) -> dict[str, int]:
        return {
            "skipped_bytes": self.reader.skipped_bytes,
            "bad_checksums": self.reader.bad_checksums,
        }


class _Nmea(_Streaming):
    """NMEA sentences, fixes and headings."""

    def __init__(self, link: Link) -> None:
        self.reader = NmeaReader()

    def feed(self, data: bytes, stamp: float) -> list[SensorFrame]:
        return self.reader.feed(data, stamp)

    def counts(self) -> dict[str, int]:
        reader = self.reader
        return {
            "bad_checksums": reader.bad_checksums,
            "unparsed": reader.unparsed,
            "out_of_range": reader.out_of_range,
            "not_measured": reader.not_measured,
        }


@dataclass(frozen=True, slots=True)
class SensorKind:
    """What a kind of device is to navd and how it is read.

    Attributes:
        role: the navd role its frames go under.
        baud: the device's usual serial rate.
        decoder: makes a fresh decoder for a program's link.
    """

    role: Role
    baud: int
    decoder: Callable[[Link], Decoder]


KINDS: dict[str, SensorKind] = {
    "rplidar": SensorKind("lidar", 115200, lambda link: _Rplidar(link, None)),
    "rplidar-express": SensorKind("lidar", 115200, lambda link: _Rplidar(link, "express")),
    "ld06": SensorKind("lidar", 230400, _Ld06),
    "ld19": SensorKind("lidar", 230400, _Ld06),
    "stl19p": SensorKind("lidar", 230400, _Ld06),
    "nmea": SensorKind("gps", 9600, _Nmea),
    "mcu": SensorKind("contact", 115200, lambda link: McuLines()),
    "tfmini": SensorKind(
        "range", 115200, lambda link: Tfmini(range_max_m=link.range_max_m or RANGE_MAX_TFMINI_M)
    ),
}
