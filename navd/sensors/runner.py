"""A sensor program's loop: a device on a serial port on one side, navd on the other.

Each side is (re)opened with backoff (``BACKOFF_S`` doubling to ``MAX_BACKOFF_S``), so the
program may start before the device is plugged in or before navd runs, and outlives both
coming and going: a port that vanishes, a device that stops answering, a daemon restarted.

The port is read as bytes arrive (a wait on the port, then whatever it holds), at most every
``READ_PAUSE_S``: a turn's scan leaves for navd within milliseconds of its last packet, and
the decoder places each packet in time by the device's own clock or by when its bytes came,
never by when the program happened to read them. Bytes become frames through the kind's
decoder; bad bytes and checksum failures are counted. Every kind of trouble is logged once
when it starts (again if its reason changes) and once when it ends, never once per byte; the
counts are logged every ``SUMMARY_PERIOD_S``. Bytes that keep coming without one good frame
for ``WRONG_KIND_S`` are logged as such: the device is likely not the kind given, or not at
that baud rate. navd sees the device go stale by itself when its frames stop.
"""

from __future__ import annotations

import contextlib
import os
import select
import threading
import time

import serial

from navd.drivers import open_exclusive
from navd.logs import get_logger
from navd.sensors.connections import Connections
from navd.sensors.kinds import KINDS
from navd.sensors.link import Link
from navd.wire import Client, ClientError

__all__ = ["Trouble", "drain_replies", "run_sensor"]

BACKOFF_S = 0.5
MAX_BACKOFF_S = 10.0
SILENT_S = 2.0  # [s] an open device that sends nothing this long is reported silent
SUMMARY_PERIOD_S = 60.0
WAIT_S = 0.05  # [s] longest wait for bytes before looking at the clock again
READ_PAUSE_S = 0.01  # [s] least time between two reads: a wakeup carries a few packets
WRONG_KIND_S = 3.0  # [s] of bytes without a good frame: the device is likely another kind
WRONG_KIND_BYTES = 2000
LEFT_OUT = frozenset({"not_measured"})  # counters of good input left out on purpose


class Trouble:
    """Each kind of trouble logged once when it begins (again when its ``error`` changes:
    navd refused, then full, then down) and once when it ends."""

    def __init__(self) -> None:
        self.log = get_logger("sensor")
        self._active: dict[str, object] = {}

    def begin(self, event: str, **fields: object) -> None:
        reason = fields.get("error")
        if event not in self._active or self._active[event] != reason:
            self._active[event] = reason
            self.log.warning(event, **fields)

    def end(self, trouble: str, event: str, **fields: object) -> None:
        if trouble in self._active:
            del self._active[trouble]
            self.log.info(event, **fields)


class _Program:
    """One sensor program's state: its device, its connection to navd, its decoder."""

    def __init__(self, kind: str, link: Link) -> None:
        self.sensor = KINDS[kind]
        self.kind = kind
        self.link = link
        self.decoder = self.sensor.decoder(link)
        self.trouble = Trouble()
        self.device: serial.Serial | None = None
        self.navd_links = Connections(link, self.sensor.role)
        self.backoff = BACKOFF_S
        self.heard_at = self.asked_at = time.monotonic()
        self.summary_at = time.monotonic()
        self.logged: dict[str, int] = {}
        self.navd = f"{link.host}:{link.navd_port}"
        self.framed_at = time.monotonic()  # when the last good frame came
        self.unframed_bytes = 0  # bytes since then

    def open_device(self) -> bool:
        try:
            self.device = open_exclusive(self.link.port, self.link.baud, timeout=0)
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
        try:
            self.navd_links.open(self.sensor.role)
        except ClientError as err:
            self.trouble.begin("navd_unreachable", navd=self.navd, error=str(err))
            return False
        self.trouble.end("navd_unreachable", "navd_connected", navd=self.navd)
        self.trouble.end("navd_lost", "navd_connected", navd=self.navd)
        return True

    def step(self) -> None:
        """Wait for the device's bytes, and send navd the frames they make."""
        device = self.device
        assert device is not None and self.navd_links.connected
        try:
            ready = select.select([device.fileno()], [], [], WAIT_S)[0]
            data = device.read(max(device.in_waiting, 1)) if ready else b""
        except (serial.SerialException, OSError, ValueError) as err:
            self._lose_device(err)
            return
        now = time.monotonic()
        try:
            self.decoder.tick(now)
        except (serial.SerialException, OSError) as err:
            self._lose_device(err)
            return
        if not data:
            if now - self.heard_at > SILENT_S:
                silent_s = round(now - self.heard_at, 1)
                self.trouble.begin("device_silent", port=self.link.port, silent_s=silent_s)
                if now - self.asked_at > SILENT_S:  # a device that must be asked: ask again
                    self.asked_at = now
                    try:
                        self.decoder.silent()
                    except (serial.SerialException, OSError) as err:
                        self._lose_device(err)
            return
        self.heard_at = now
        self.trouble.end("device_silent", "device_speaks", port=self.link.port)
        try:
            frames = self.decoder.feed(data, now)
            self.navd_links.send(frames)
            for client in self.navd_links.clients.values():
                drain_replies(client, self.trouble)
        except (OSError, ClientError) as err:
            self.trouble.begin("navd_lost", navd=self.navd, error=str(err))
            self.navd_links.close()
            return
        self._framing(now, len(data), bool(frames))
        self.count(now)
        time.sleep(READ_PAUSE_S)  # let a few packets gather: fewer wakeups, same latency

    def _lose_device(self, err: Exception) -> None:
        self.trouble.begin("device_lost", port=self.link.port, error=str(err))
        if self.device is not None:
            with contextlib.suppress(OSError, serial.SerialException):
                self.device.close()
        self.device = None

    def _framing(self, now: float, received: int, framed: bool) -> None:
        """Bytes that keep coming without a good frame: say what is likely wrong, once."""
        if framed:
            self.framed_at, self.unframed_bytes = now, 0
            self.trouble.end("not_this_kind", "device_frames", port=self.link.port)
            return
        self.unframed_bytes += received
        skipped = self.decoder.counts().get("skipped_bytes", 0)
        if (
            now - self.framed_at > WRONG_KIND_S
            and self.unframed_bytes > WRONG_KIND_BYTES
            and skipped > self.unframed_bytes // 2
        ):
            self.trouble.begin(
                "not_this_kind",
                port=self.link.port,
                kind=self.kind,
                baud=self.link.baud,
                bytes_without_a_frame=self.unframed_bytes,
                error=f"no {self.kind} frame in {self.unframed_bytes} bytes: is the device a "
                f"{self.kind}, at {self.link.baud} baud? (KIND, --baud)",
            )

    def count(self, now: float) -> None:
        """Log each counter the first time it moves, and all of them now and then."""
        counts = self.decoder.counts()
        for name, count in counts.items():
            if count and not self.logged.get(name):
                # what the device says of itself (a receiver dead reckoning) is no bad input
                event = "input_left_out" if name in LEFT_OUT else "bad_input"
                self.trouble.log.warning(event, counter=name, count=count)
            self.logged[name] = count
        if now - self.summary_at >= SUMMARY_PERIOD_S:
            self.summary_at = now
            self.trouble.log.info("sensor_counts", **counts)

    def close(self) -> None:
        if self.device is not None:
            self.decoder.closing(self.device)
            self.device.close()
        self.navd_links.close()


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
                program.navd_links.connected or program.connect()
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
            trouble.begin("navd_refused_frames", error=text)
