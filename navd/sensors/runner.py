"""A sensor program's loop: a device on a serial port on one side, navd on the other.

Each side is (re)opened with backoff (``BACKOFF_S`` doubling to ``MAX_BACKOFF_S``), so the
program may start before the device is plugged in or before navd runs, and outlives both
coming and going: a port that vanishes, a device that stops answering, a daemon restarted.
Bytes become frames through the kind's decoder; bad bytes and checksum failures are counted.
Every kind of trouble is logged once when it starts (and once when it ends), never once per
byte; the counts are logged every ``SUMMARY_PERIOD_S``. navd sees the device go stale by
itself when its frames stop.
"""

from __future__ import annotations

import contextlib
import os
import select
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

import serial

from navd.drivers import open_exclusive
from navd.logs import get_logger
from navd.sensors.ld06 import PacketReader, ScanAssembler
from navd.sensors.nmea import NmeaReader
from navd.sensors.rplidar import RplidarDecoder, ScanMode
from navd.wire import Client, ClientError, Role, SensorFrame

__all__ = ["KINDS", "Decoder", "Link", "SensorKind", "Trouble", "drain_replies", "run_sensor"]

BACKOFF_S = 0.5
MAX_BACKOFF_S = 10.0
SILENT_S = 2.0  # [s] an open device that sends nothing this long is reported silent
SUMMARY_PERIOD_S = 60.0
READ_BYTES = 4096


class Decoder(Protocol):
    """A device's bytes in, navd's frames out; a device that must be asked to send is asked
    when its port opens, and asked again when it falls silent."""

    def feed(self, data: bytes, stamp: float) -> list[SensorFrame]: ...

    def counts(self) -> dict[str, int]: ...

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


def _set_dtr(device: serial.Serial) -> Callable[[bool], None]:
    def set_dtr(level: bool) -> None:
        # a pseudo-terminal or an adapter without modem lines has no DTR: nothing to do
        with contextlib.suppress(OSError, serial.SerialException):
            device.dtr = level

    return set_dtr


class _Rplidar:
    """A Slamtec RPLIDAR: asked for its health, info and scan; one scan per turn."""

    def __init__(self, mode: ScanMode) -> None:
        self.log = get_logger("sensor")
        self.lidar = RplidarDecoder(mode, notes=self._note)

    def _note(self, event: str, fields: dict[str, object]) -> None:
        level = self.log.info if event == "lidar_info" else self.log.warning
        level(event, **fields)

    def feed(self, data: bytes, stamp: float) -> list[SensorFrame]:
        return self.lidar.feed(data, stamp)

    def counts(self) -> dict[str, int]:
        return self.lidar.counts()

    def opened(self, device: serial.Serial) -> None:
        self.lidar.opened(device.write, _set_dtr(device))

    def silent(self) -> None:
        self.lidar.restart()

    def closing(self, device: serial.Serial) -> None:
        with contextlib.suppress(OSError, serial.SerialException):
            self.lidar.closing(_set_dtr(device))


class _Ld06(_Streaming):
    """LD06 packets, one scan per turn."""

    def __init__(self) -> None:
        self.reader = PacketReader()
        self.turns = ScanAssembler()

    def feed(self, data: bytes, stamp: float) -> list[SensorFrame]:
        frames: list[SensorFrame] = []
        for packet in self.reader.feed(data):
            scan = self.turns.add(packet, stamp)
            if scan is not None:
                frames.append(scan)
        return frames

    def counts(self) -> dict[str, int]:
        return {
            "skipped_bytes": self.reader.skipped_bytes,
            "bad_checksums": self.reader.bad_checksums,
        }


class _Nmea(_Streaming):
    """NMEA sentences, fixes and headings."""

    def __init__(self) -> None:
        self.reader = NmeaReader()

    def feed(self, data: bytes, stamp: float) -> list[SensorFrame]:
        return self.reader.feed(data, stamp)

    def counts(self) -> dict[str, int]:
        return {"bad_checksums": self.reader.bad_checksums, "unparsed": self.reader.unparsed}


@dataclass(frozen=True, slots=True)
class SensorKind:
    """What a kind of device is to navd and how it is read.

    Attributes:
        role: the navd role its frames go under.
        baud: the device's usual serial rate.
        decoder: makes a fresh decoder.
    """

    role: Role
    baud: int
    decoder: Callable[[], Decoder]


KINDS: dict[str, SensorKind] = {
    "rplidar": SensorKind("lidar", 115200, lambda: _Rplidar(ScanMode.STANDARD)),
    "rplidar-express": SensorKind("lidar", 115200, lambda: _Rplidar(ScanMode.EXPRESS)),
    "ld06": SensorKind("lidar", 230400, _Ld06),
    "ld19": SensorKind("lidar", 230400, _Ld06),
    "stl19p": SensorKind("lidar", 230400, _Ld06),
    "nmea": SensorKind("gps", 9600, _Nmea),
}


class Trouble:
    """Each kind of trouble logged once when it begins and once when it ends."""

    def __init__(self) -> None:
        self.log = get_logger("sensor")
        self._active: set[str] = set()

    def begin(self, kind: str, **fields: object) -> None:
        if kind not in self._active:
            self._active.add(kind)
            self.log.warning(kind, **fields)

    def end(self, kind: str, event: str, **fields: object) -> None:
        if kind in self._active:
            self._active.discard(kind)
            self.log.info(event, **fields)


@dataclass(frozen=True, slots=True)
class Link:
    """Where a sensor program reads and where it sends.

    Attributes:
        port, baud: the device's serial port and rate.
        host, navd_port: where navd listens.
        device_id: the name navd knows the device by.
        token: navd's ``tcp.token``, when it has one.
    """

    port: str
    baud: int
    host: str
    navd_port: int
    device_id: str
    token: str | None = None


class _Program:
    """One sensor program's state: its device, its connection to navd, its decoder."""

    def __init__(self, kind: str, link: Link) -> None:
        self.sensor = KINDS[kind]
        self.link = link
        self.decoder = self.sensor.decoder()
        self.trouble = Trouble()
        self.device: serial.Serial | None = None
        self.client: Client | None = None
        self.backoff = BACKOFF_S
        self.heard_at = self.asked_at = time.monotonic()
        self.summary_at = time.monotonic()
        self.logged: dict[str, int] = {}
        self.navd = f"{link.host}:{link.navd_port}"

    def open_device(self) -> bool:
        try:
            self.device = open_exclusive(self.link.port, self.link.baud, timeout=0.1)
        except (serial.SerialException, OSError) as err:
            self.trouble.begin("device_unavailable", port=self.link.port, error=str(err))
            return False
        self.trouble.end("device_unavailable", "device_opened", port=self.link.port)
        self.trouble.end("device_lost", "device_opened", port=self.link.port)
        self.heard_at = self.asked_at = time.monotonic()
        try:
            self.decoder.opened(self.device)
        except (serial.SerialException, OSError) as err:
            self.trouble.begin("device_lost", port=self.link.port, error=str(err))
            self.device.close()
            self.device = None
            return False
        return True

    def connect(self) -> bool:
        link = self.link
        try:
            self.client = Client(
                link.host,
                link.navd_port,
                role=self.sensor.role,
                device_id=link.device_id,
                token=link.token,
            )
        except ClientError as err:
            self.trouble.begin("navd_unreachable", navd=self.navd, error=str(err))
            return False
        self.trouble.end("navd_unreachable", "navd_connected", navd=self.navd)
        self.trouble.end("navd_lost", "navd_connected", navd=self.navd)
        return True

    def step(self) -> None:
        """Read what the device sent, and send navd the frames it makes."""
        assert self.device is not None and self.client is not None
        try:
            data = self.device.read(READ_BYTES)
        except (serial.SerialException, OSError) as err:
            self.trouble.begin("device_lost", port=self.link.port, error=str(err))
            self.device.close()
            self.device = None
            return
        now = time.monotonic()
        if not data:
            if now - self.heard_at > SILENT_S:
                silent_s = round(now - self.heard_at, 1)
                self.trouble.begin("device_silent", port=self.link.port, silent_s=silent_s)
                if now - self.asked_at > SILENT_S:  # a device that must be asked: ask again
                    self.asked_at = now
                    try:
                        self.decoder.silent()
                    except (serial.SerialException, OSError) as err:
                        self.trouble.begin("device_lost", port=self.link.port, error=str(err))
                        self.device.close()
                        self.device = None
            return
        self.heard_at = now
        self.trouble.end("device_silent", "device_speaks", port=self.link.port)
        try:
            for frame in self.decoder.feed(data, now):
                self.client.send(frame)
            drain_replies(self.client, self.trouble)
        except OSError as err:
            self.trouble.begin("navd_lost", navd=self.navd, error=str(err))
            self.client.close()
            self.client = None
        self.count(now)

    def count(self, now: float) -> None:
        """Log each counter the first time it moves, and all of them now and then."""
        counts = self.decoder.counts()
        for name, count in counts.items():
            if count and not self.logged.get(name):
                self.trouble.log.warning("bad_input", counter=name, count=count)
            self.logged[name] = count
        if now - self.summary_at >= SUMMARY_PERIOD_S:
            self.summary_at = now
            self.trouble.log.info("sensor_counts", **counts)

    def close(self) -> None:
        if self.device is not None:
            self.decoder.closing(self.device)
            self.device.close()
        if self.client is not None:
            self.client.close()


def run_sensor(kind: str, link: Link, stop: threading.Event | None = None) -> None:
    """Read ``link.port`` and stream to navd until ``stop`` is set (Ctrl-C otherwise)."""
    stop = stop or threading.Event()
    program = _Program(kind, link)
    program.trouble.log.info(
        "sensor_started", kind=kind, port=link.port, baud=link.baud, device_id=link.device_id
    )
    try:
        while not stop.is_set():
            ready = (program.device is not None or program.open_device()) and (
                program.client is not None or program.connect()
            )
            if not ready:
                stop.wait(program.backoff)
                program.backoff = min(program.backoff * 2, MAX_BACKOFF_S)
                continue
            program.backoff = BACKOFF_S
            program.step()
    finally:
        program.close()


def drain_replies(client: Client, trouble: Trouble) -> None:
    """Read what navd sent without waiting (its error frames, said once), so nothing piles
    up unread."""
    while select.select([client.sock], [], [], 0.0)[0]:
        data = os.read(client.sock.fileno(), 65536)
        if not data:
            raise ConnectionResetError("navd closed the connection")
        if b'"error"' in data:
            text = data.decode("utf-8", errors="replace").strip().splitlines()[0][:300]
            trouble.begin("navd_refused_frames", said=text)
