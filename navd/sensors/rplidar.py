"""A Slamtec RPLIDAR on a serial port: the conversation that starts it, and turns as scans.

The conversation (``rplidar_protocol`` has the bytes): STOP, then GET_HEALTH (a health
error is answered with RESET, and the banner the lidar prints while it restarts is read as
such, not as bad input), GET_INFO (model, firmware, serial: logged once), the A2/A3 motor's
PWM, then the scan modes by GET_LIDAR_CONF: how many, the typical one, and each one's name,
longest range, time per sample and answer type. A firmware that does not answer those
(before 1.24) is offered the two modes every RPLIDAR has, Standard and Express. The mode
asked for by name (``--scan-mode``) is started, else the lidar's typical mode when navd reads
its answers (standard samples, express and dense capsules; not ultra capsules), else the
readable mode with the most samples a second. ``range_max`` is the mode's own, else the
series' (A1/A2/C1 12 m, A3 25 m, S1 40 m), unless given.

Requests keep Slamtec's spacing: nothing within ``STOP_GAP_S`` after STOP, nothing until
``RESET_SETTLE_S`` after RESET. A request left unanswered for ``ANSWER_TIMEOUT_S`` is logged
with what was asked and the conversation starts again; after ``RETRIES`` of those, with a
RESET.

The scan's bytes become turns in ``rplidar_stream``; the A1's motor runs while the
adapter's DTR line is low.
"""

from __future__ import annotations

import enum
import math
import struct
import time
from collections.abc import Callable

from navd.sensors.rplidar_modes import ModeQuery, choose_mode
from navd.sensors.rplidar_protocol import (
    ANSWER,
    DESCRIPTOR_BYTES,
    READABLE,
    SYNC,
    Answer,
    Command,
    RplidarInfo,
    ScanModeInfo,
    request,
    series_range_max_m,
)
from navd.sensors.rplidar_stream import ScanStream, StreamCounts
from navd.sensors.turn_builder import TurnBuilder
from navd.wire import SensorFrame

__all__ = ["LEGACY_MODES", "RplidarDecoder"]

DEFAULT_PWM = 660  # the A2/A3 motor duty Slamtec's SDK starts with
RANGE_MIN_M = 0.15
STOP_GAP_S = 0.002  # [s] after STOP, before the next request (Slamtec asks for 1 ms)
RESET_SETTLE_S = 0.5  # [s] after RESET, before the next request (the core restarts)
ANSWER_TIMEOUT_S = 1.0  # [s] a request this long unanswered is asked again
CONF_TIMEOUT_S = 0.3  # [s] GET_LIDAR_CONF this long unanswered: an older firmware
RETRIES = 3  # unanswered conversations before a RESET
BANNER_CHARS = 200
# The modes of a firmware that does not describe its own (Standard: 2 kHz on the A1).
LEGACY_MODES = (
    ScanModeInfo(0, "Standard", math.nan, 500.0, Answer.SCAN),
    ScanModeInfo(0, "Express", math.nan, 250.0, Answer.EXPRESS),
)

_DESCRIPTOR = struct.Struct("<BBIB")
_SAMPLE = struct.Struct("<BBBH")


class _Step(enum.Enum):
    """Where the conversation is."""

    IDLE = "idle"
    HEALTH = "health"
    INFO = "info"
    CONF = "conf"
    RESET = "reset"
    SCAN = "scan"


class RplidarDecoder:
    """Talks to one RPLIDAR and turns its samples into one ScanFrame per turn.

    Args:
        mode: the scan mode by name ("standard", "express", "denseboost"...; any case), or
            None for the lidar's own choice (see the module docstring).
        baud: the line's rate [bit/s] (for the bytes' time on the line).
        range_max_m: [m] overrides the mode's longest range.
        notes: told what the lidar says of itself and what goes wrong, for the log.
        clock, sleep: time.monotonic and time.sleep (tests give their own).

    Attributes:
        info: what the lidar said it is, once it has.
        modes: its scan modes, once known; ``scan_mode`` the one running.
        skipped_bytes, bad_checksums, health_errors, banner_bytes: counts.
    """

    def __init__(
        self,
        mode: str | None = None,
        *,
        baud: int = 115200,
        range_max_m: float | None = None,
        notes: Callable[[str, dict[str, object]], None] = lambda event, fields: None,
        clock: Callable[[], float] = time.monotonic,
        sleep: Callable[[float], None] = time.sleep,
    ) -> None:
        self.wanted = mode.lower() if mode else None
        self.byte_s = 10.0 / baud
        self.range_max_m = range_max_m
        self.notes = notes
        self.clock = clock
        self.sleep = sleep
        self.info: RplidarInfo | None = None
        self.modes: list[ScanModeInfo] = []
        self.scan_mode: ScanModeInfo | None = None
        self.skipped_bytes = self.health_errors = self.banner_bytes = 0
        self._write: Callable[[bytes], None] = lambda data: None
        self._buffer = bytearray()
        self._step = _Step.IDLE
        self._asked: tuple[str, float] = ("", math.inf)  # what was asked, and when
        self._quiet_until = 0.0  # no request before this [s]
        self._failures = 0
        self._stream: ScanStream | None = None
        self._streamed = StreamCounts()  # bad input of every stream so far
        self._modes = ModeQuery()
        self._banner = bytearray()
        self.turns = TurnBuilder(RANGE_MIN_M, range_max_m or 12.0)

    # --- the device's side --------------------------------------------------------------

    def opened(self, write: Callable[[bytes], None], set_dtr: Callable[[bool], None]) -> None:
        """The port is open: start the A1's motor (DTR low) and the conversation."""
        self._write = write
        set_dtr(False)
        self.restart()

    def restart(self) -> None:
        """Start the conversation over: stop any scan, then ask its health."""
        self._send(request(Command.STOP))
        self._quiet_until = self.clock() + STOP_GAP_S
        self._ask(request(Command.GET_HEALTH), _Step.HEALTH, "GET_HEALTH")

    def closing(self, set_dtr: Callable[[bool], None]) -> None:
        """Stop the scan and the motor before the port closes."""
        self._send(request(Command.STOP))
        self._quiet_until = self.clock() + STOP_GAP_S
        if self.info is not None and self.info.spins_by_pwm:
            self._send(request(Command.SET_MOTOR_PWM, struct.pack("<H", 0)))
        set_dtr(True)

    def tick(self, now: float) -> None:
        """Time passed: a reset that has settled is followed up, an unanswered request
        asked again (see the module docstring)."""
        what, asked_at = self._asked
        if self._step is _Step.RESET and now >= self._quiet_until:
            if self._banner:
                text = self._banner.decode("ascii", errors="replace").strip()
                self.notes("lidar_reset_banner", {"text": text[:BANNER_CHARS]})
                self._banner.clear()
            self._ask(request(Command.GET_HEALTH), _Step.HEALTH, "GET_HEALTH")
        elif self._step is _Step.CONF and now - asked_at > CONF_TIMEOUT_S:
            self.notes("lidar_modes_unknown", {"asked": what, "using": "Standard, Express"})
            self._start(list(LEGACY_MODES))
        elif self._step in (_Step.HEALTH, _Step.INFO) and now - asked_at > ANSWER_TIMEOUT_S:
            self._failures += 1
            self.notes("lidar_not_answering", {"asked": what, "tries": self._failures})
            if self._failures % RETRIES == 0:
                self._reset()
            else:
                self.restart()

    def _send(self, data: bytes) -> None:
        wait = self._quiet_until - self.clock()
        if wait > 0:
            self.sleep(wait)
        # A new request ends what was being streamed: the next bytes answer it.
        self._stream = None
        self._buffer.clear()
        self._write(data)

    def _ask(self, data: bytes, step: _Step, what: str) -> None:
        self._send(data)
        self._step = step
        self._asked = (what, self.clock())

    def _reset(self) -> None:
        self._send(request(Command.RESET))
        self._step = _Step.RESET
        self._quiet_until = self.clock() + RESET_SETTLE_S
        self.turns.clear()

    # --- bytes in, frames out -----------------------------------------------------------

    def feed(self, data: bytes, read_s: float) -> list[SensorFrame]:
        """Take bytes read at ``read_s`` [s]; the turns they completed."""
        if self._step is _Step.RESET:  # the banner the lidar prints as it restarts
            self.banner_bytes += len(data)
            self._banner.extend(data[: max(BANNER_CHARS - len(self._banner), 0)])
            return []
        self._buffer.extend(data)
        while self._stream is None:
            if not self._descriptor():
                return []
        return list(self._stream.take(self._buffer, read_s))

    def counts(self) -> dict[str, int]:
        return {
            "skipped_bytes": self.skipped_bytes + self._streamed.skipped_bytes,
            "bad_checksums": self._streamed.bad_checksums,
            "health_errors": self.health_errors,
        }

    def _skip(self, count: int) -> None:
        self.skipped_bytes += count
        del self._buffer[:count]

    def _arrival(self, read_s: float) -> float:
        """[s] when the bytes just taken off the buffer arrived at the latest."""
        return read_s - len(self._buffer) * self.byte_s

    def _descriptor(self) -> bool:
        """Read one answer (a descriptor and, for single answers, its data); False when more
        bytes are needed."""
        buffer = self._buffer
        start = buffer.find(bytes([SYNC, ANSWER]))
        if start < 0:
            self._skip(len(buffer) - (1 if buffer and buffer[-1] == SYNC else 0))
            return False
        if start:
            self._skip(start)
        if len(buffer) < DESCRIPTOR_BYTES:
            return False
        _, _, size_mode, kind = _DESCRIPTOR.unpack_from(buffer)
        size, multiple = size_mode & 0x3FFFFFFF, size_mode >> 30 == 1
        if multiple and kind in READABLE:
            del buffer[:DESCRIPTOR_BYTES]
            mode = self.scan_mode
            self._stream = ScanStream(
                Answer(kind), self.byte_s, self.turns, mode.us_per_sample if mode else 0.0
            )
            self._streamed.add(self._stream)
            self._step = _Step.SCAN
            return True
        if len(buffer) < DESCRIPTOR_BYTES + size:
            return False
        body = bytes(buffer[DESCRIPTOR_BYTES : DESCRIPTOR_BYTES + size])
        del buffer[: DESCRIPTOR_BYTES + size]
        if kind == Answer.HEALTH and size == 3 and self._step is _Step.HEALTH:
            self._health(body)
        elif kind == Answer.INFO and size == 20 and self._step is _Step.INFO:
            self._info(body)
        elif kind == Answer.LIDAR_CONF and self._step is _Step.CONF and self._modes.answer(body):
            self._next_question()
        else:
            self.skipped_bytes += DESCRIPTOR_BYTES + size  # an answer not asked for
        return True

    def _health(self, body: bytes) -> None:
        status, error = struct.unpack("<BH", body)
        if status == 2:
            self.health_errors += 1
            self.notes("lidar_health_error", {"error_code": error})
            self._reset()  # the protocol's remedy
            return
        if status == 1:
            self.notes("lidar_health_warning", {"error_code": error})
        self._ask(request(Command.GET_INFO), _Step.INFO, "GET_INFO")

    def _info(self, body: bytes) -> None:
        model, minor, major, hardware = body[:4]
        self.info = RplidarInfo(model, f"{major}.{minor:02d}", hardware, body[4:20].hex().upper())
        self._failures = 0
        self.notes(
            "lidar_info",
            {
                "series": self.info.series,
                "firmware": self.info.firmware,
                "serial": self.info.serial,
            },
        )
        if self.info.spins_by_pwm:
            self._send(request(Command.SET_MOTOR_PWM, struct.pack("<H", DEFAULT_PWM)))
        self._modes = ModeQuery()
        self._next_question()

    def _next_question(self) -> None:
        question = self._modes.next_request()
        if question is None:
            self._start(self._modes.modes())
        else:
            self._ask(question, _Step.CONF, self._modes.asking)

    def _start(self, modes: list[ScanModeInfo]) -> None:
        """Choose the scan mode and start it."""
        self.modes = modes
        chosen = choose_mode(modes, self.wanted)
        if chosen is None:
            self.notes(
                "lidar_scan_mode_refused",
                {"asked": self.wanted, "readable": [m.name for m in modes if m.readable]},
            )
            self._step = _Step.IDLE
            return
        self.scan_mode = chosen
        if self.range_max_m is None:
            known = chosen.max_distance_m
            self.turns.range_max_m = known if known > 0 else series_range_max_m(self.info)
        self.notes(
            "lidar_scan_mode",
            {
                "mode": chosen.name,
                "range_max_m": self.turns.range_max_m,
                "samples_per_s": round(1e6 / chosen.us_per_sample),
                "modes": [m.name for m in modes],
            },
        )
        if chosen.answer == Answer.SCAN and chosen.mode_id == 0:
            self._ask(request(Command.SCAN), _Step.SCAN, "SCAN")
        else:  # working mode, then four reserved bytes
            payload = struct.pack("<BI", chosen.mode_id, 0)
            self._ask(request(Command.EXPRESS_SCAN, payload), _Step.SCAN, "EXPRESS_SCAN")
