"""A Slamtec RPLIDAR as its interface protocol document describes it (A1, A2, A3, C1, S1).

It answers STOP, RESET, GET_HEALTH, GET_INFO, GET_LIDAR_CONF (from firmware 1.24), SCAN,
EXPRESS_SCAN and SET_MOTOR_PWM, and streams standard samples (5 bytes), express capsules
(84 bytes, 32 samples with angle offsets) or dense capsules (84 bytes, 40 samples) of a room
whose range is a function of the clockwise angle, at the model's sample rate and baud rate.
As the document asks of the host, a request that comes within 1 ms of a STOP is not heard,
nor one while the core restarts after RESET (it prints its banner meanwhile). A device that
is ``frozen`` stops sending and hears nothing, as a hung lidar, and comes back idle.

Bytes are made here from the document's tables, not with navd's ``sensors.rplidar``; the
tests read them with the rplidar and pyrplidar packages, and with navd's program.
"""

from __future__ import annotations

import math
import struct
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field

from navd.sim.devices.serial_line import SerialLine, UartWriter

__all__ = ["MODELS", "RplidarDevice", "RplidarModel", "RplidarTurn", "ScanMode"]

STOP_DEAF_S = 0.001  # [s] a request this soon after STOP is not heard
RESET_BOOT_S = 0.3  # [s] the core restarts: nothing is heard meanwhile
BANNER = b"RP LIDAR System.\r\nFirmware Ver 1.29 - rc9, HW Ver 7\r\nModel: 18\r\n"


@dataclass(frozen=True, slots=True)
class ScanMode:
    """A scan mode: its name, answer type, [µs] per sample and [m] longest range."""

    name: str
    answer: int
    us_per_sample: float
    max_distance_m: float


@dataclass(frozen=True, slots=True)
class RplidarModel:
    """What a model says of itself and how it scans.

    Attributes:
        model: GET_INFO's model byte; firmware (major, minor); baud: its line rate.
        modes: its scan modes (mode 0 is Standard); typical: the mode it recommends.
        describes_modes: whether it answers GET_LIDAR_CONF (firmware 1.24 and later).
        turn_hz: its turns a second.
    """

    model: int
    firmware: tuple[int, int]
    baud: int
    modes: tuple[ScanMode, ...]
    typical: int
    describes_modes: bool
    turn_hz: float


MODELS = {
    "A1": RplidarModel(
        0x18,
        (1, 29),
        115200,
        (ScanMode("Standard", 0x81, 500.0, 12.0), ScanMode("Express", 0x82, 250.0, 12.0)),
        1,
        True,
        5.5,
    ),
    "A1-old": RplidarModel(
        0x18, (1, 20), 115200, (ScanMode("Standard", 0x81, 500.0, 12.0),), 0, False, 5.5
    ),
    "A2": RplidarModel(
        0x28,
        (1, 27),
        115200,
        (ScanMode("Standard", 0x81, 250.0, 12.0), ScanMode("Express", 0x82, 125.0, 12.0)),
        1,
        True,
        10.0,
    ),
    "C1": RplidarModel(
        0x41,
        (1, 1),
        460800,
        (ScanMode("Standard", 0x81, 200.0, 12.0), ScanMode("DenseBoost", 0x85, 200.0, 12.0)),
        1,
        True,
        10.0,
    ),
    "S1": RplidarModel(
        0x61,
        (1, 28),
        256000,
        (ScanMode("Standard", 0x81, 244.0, 40.0), ScanMode("DenseBoost", 0x85, 108.0, 40.0)),
        1,
        True,
        10.0,
    ),
    "A3": RplidarModel(
        0x38,
        (1, 29),
        256000,
        (
            ScanMode("Standard", 0x81, 250.0, 25.0),
            ScanMode("Express", 0x82, 125.0, 25.0),
            ScanMode("Sensitivity", 0x84, 63.0, 25.0),
        ),
        2,
        True,
        10.0,
    ),
}


def _descriptor(size: int, multiple: bool, kind: int) -> bytes:
    """A5 5A, then the 30-bit size with the 2-bit send mode, then the data type."""
    return bytes([0xA5, 0x5A]) + struct.pack("<I", size | (int(multiple) << 30)) + bytes([kind])


def _sample(angle_deg: float, distance_m: float, start: bool, quality: int) -> bytes:
    """A standard sample; ``quality`` is 6 bits (0-63, clamped)."""
    quality = max(0, min(quality, 63))
    angle_q6 = round(angle_deg * 64) & 0x7FFF
    flags = (quality << 2) | ((not start) << 1) | int(start)
    distance_q2 = min(round(distance_m * 4000), 0xFFFF)
    return bytes([flags, ((angle_q6 & 0x7F) << 1) | 1, angle_q6 >> 7]) + struct.pack(
        "<H", distance_q2
    )


def _capsule(start_deg: float, new_scan: bool, body: bytes) -> bytes:
    head = struct.pack("<H", (round(start_deg * 64) & 0x7FFF) | (0x8000 if new_scan else 0))
    checksum = 0
    for byte in head + body:
        checksum ^= byte
    return bytes([0xA0 | (checksum & 0xF), 0x50 | (checksum >> 4)]) + head + body


@dataclass(frozen=True, slots=True)
class RplidarTurn:
    """[s, time.monotonic] of a turn's first and last samples (from the front, clockwise)."""

    first_s: float
    last_s: float


@dataclass
class RplidarDevice:
    """The device's side of the line.

    Args:
        room: [m] range and quality (0-63) at a clockwise angle [deg]; range 0: no return.
        model: one of ``MODELS``.
        health: the GET_HEALTH status (0 good, 1 warning, 2 error) until a RESET.

    Attributes:
        requests: the command bytes heard, in order; ``deaf_requests`` those not heard.
        pwm: the motor duties set.
        streaming: the answer type being streamed, or None.
        turns: the turns streamed so far; frozen: set to hang the device.
    """

    room: Callable[[float], tuple[float, int]]
    model: str = "A1"
    health: int = 0
    requests: list[int] = field(default_factory=list)
    deaf_requests: list[int] = field(default_factory=list)
    pwm: list[int] = field(default_factory=list)
    streaming: int | None = None
    turns: list[RplidarTurn] = field(default_factory=list)
    frozen: threading.Event = field(default_factory=threading.Event)
    _pending: bytearray = field(default_factory=bytearray)
    _deaf_until: float = -math.inf
    _mode: ScanMode | None = None
    _sample_index: int = 0
    _stream_start: float = 0.0
    _new_scan: bool = True
    _turn_first: float = 0.0

    @property
    def spec(self) -> RplidarModel:
        return MODELS[self.model]

    # --- the host's requests ------------------------------------------------------------

    def hear(self, data: bytes, now: float) -> bytes:
        """Take the host's bytes arriving at ``now`` [s]; the answers they ask for."""
        self._pending.extend(data)
        out = b""
        buf = self._pending
        while buf:
            if buf[0] != 0xA5:
                del buf[:1]
                continue
            if len(buf) < 2:
                break
            cmd = buf[1]
            payload = b""
            if cmd & 0x80:  # a command with a payload: size, payload, checksum
                if len(buf) < 3 or len(buf) < 4 + buf[2]:
                    break
                size = buf[2]
                payload = bytes(buf[3 : 3 + size])
                checksum = 0
                for byte in buf[: 3 + size]:
                    checksum ^= byte
                ok = checksum == buf[3 + size]
                del buf[: 4 + size]
                if not ok:
                    continue
            else:
                del buf[:2]
            if now < self._deaf_until:
                self.deaf_requests.append(cmd)
                continue
            self.requests.append(cmd)
            out += self._answer(cmd, payload, now)
        return out

    def _answer(self, cmd: int, payload: bytes, now: float) -> bytes:
        spec = self.spec
        if cmd == 0x25:  # STOP
            self.streaming = None
            self._deaf_until = now + STOP_DEAF_S
            return b""
        if cmd == 0x40:  # RESET: healthy again, after a restart that prints a banner
            self.streaming, self.health = None, 0
            self._deaf_until = now + RESET_BOOT_S
            return BANNER
        if cmd == 0x52:  # GET_HEALTH
            error = 0x8001 if self.health else 0
            return _descriptor(3, False, 0x06) + struct.pack("<BH", self.health, error)
        if cmd == 0x50:  # GET_INFO
            major, minor = spec.firmware
            return (
                _descriptor(20, False, 0x04)
                + bytes([spec.model, minor, major, 7])
                + bytes(range(16))
            )
        if cmd == 0xF0:  # SET_MOTOR_PWM
            self.pwm.append(struct.unpack("<H", payload)[0])
            return b""
        if cmd == 0x84 and spec.describes_modes:
            return self._conf(payload)
        if cmd == 0x20:  # SCAN: the standard mode
            return self._start(spec.modes[0], now)
        if cmd == 0x82:  # EXPRESS_SCAN with a working mode (0: the legacy express scan)
            mode_id = payload[0] if payload else 0
            if mode_id == 0:
                legacy = [m for m in spec.modes if m.answer == 0x82]
                return self._start(legacy[0], now) if legacy else b""
            if mode_id < len(spec.modes):
                return self._start(spec.modes[mode_id], now)
        return b""

    def _conf(self, payload: bytes) -> bytes:
        spec = self.spec
        key = struct.unpack_from("<I", payload)[0]
        mode = struct.unpack_from("<H", payload, 4)[0] if len(payload) >= 6 else 0
        if key == 0x70:
            value = struct.pack("<H", len(spec.modes))
        elif key == 0x7C:
            value = struct.pack("<H", spec.typical)
        elif mode >= len(spec.modes):
            return b""
        elif key == 0x7F:
            value = spec.modes[mode].name.encode() + b"\0"
        elif key == 0x74:
            value = struct.pack("<I", round(spec.modes[mode].max_distance_m * 256))
        elif key == 0x71:
            value = struct.pack("<I", round(spec.modes[mode].us_per_sample * 256))
        elif key == 0x75:
            value = bytes([spec.modes[mode].answer])
        else:
            return b""
        body = struct.pack("<I", key) + value
        return _descriptor(len(body), False, 0x20) + body

    def _start(self, mode: ScanMode, now: float) -> bytes:
        self._mode = mode
        self.streaming = mode.answer
        self._sample_index = 0
        self._stream_start = now
        self._new_scan = True
        size = 5 if mode.answer == 0x81 else 84
        return _descriptor(size, True, mode.answer)

    # --- what it streams ----------------------------------------------------------------

    def stream_until(self, now: float) -> tuple[bytes, float]:
        """The stream's bytes whose samples were measured by ``now`` [s], and when the
        first of them was ready (b"" when nothing is due or nothing streams)."""
        mode = self._mode
        if self.streaming is None or mode is None:
            return b"", now
        per_unit = {0x81: 1, 0x82: 32, 0x85: 40}.get(mode.answer)
        if per_unit is None:  # a mode this emulator does not stream (ultra capsules)
            return b"", now
        out = b""
        first_ready = math.inf
        sample_s = mode.us_per_sample * 1e-6
        while True:
            end = self._sample_index + per_unit
            ready = self._stream_start + end * sample_s
            if ready > now:
                return out, min(first_ready, ready)
            out += self._unit(self._sample_index, per_unit, sample_s)
            first_ready = min(first_ready, ready)
            self._sample_index = end

    def _angle(self, index: int, sample_s: float) -> float:
        return (index * sample_s * self.spec.turn_hz * 360.0) % 360.0

    def _unit(self, index: int, count: int, sample_s: float) -> bytes:
        """Samples ``index`` to ``index + count``: one standard sample or one capsule."""
        times = [self._stream_start + (index + k) * sample_s for k in range(count)]
        angles = [self._angle(index + k, sample_s) for k in range(count)]
        for k in range(count):  # a turn begins where the angle passes the front
            before = self._angle(index + k - 1, sample_s) if index + k > 0 else 360.0
            if angles[k] < before:
                if self.turns or index + k > 0:
                    self.turns.append(RplidarTurn(self._turn_first, times[k] - sample_s))
                self._turn_first = times[k]
        assert self._mode is not None
        if self._mode.answer == 0x81:
            range_m, quality = self.room(angles[0])
            start = index == 0 or angles[0] < self._angle(index - 1, sample_s)
            return _sample(angles[0], range_m if range_m > 0 else 0.0, start, quality)
        new_scan, self._new_scan = self._new_scan, False
        if self._mode.answer == 0x85:
            body = b"".join(
                struct.pack("<H", min(round(max(self.room(a)[0], 0.0) * 1000), 0xFFFF))
                for a in angles
            )
            return _capsule(angles[0], new_scan, body)
        return _capsule(angles[0], new_scan, self._express_body(angles))

    def _express_body(self, angles: list[float]) -> bytes:
        """16 cabins: each sample's distance measured at its nominal angle less an offset
        dθ (1 or 1.125 deg, in 1/8 deg), which the host takes off again. Offsets stay below
        4 deg, where the sixth bit is clear: Slamtec's SDK reads dθ as 6 bits unsigned,
        other drivers as a sign and 5 bits, and on these all readings agree."""
        body = b""
        for j in range(16):
            parts = []
            for k in (2 * j, 2 * j + 1):
                offset_q3 = 8 + k % 2
                true_deg = (angles[k] - offset_q3 / 8.0) % 360.0
                parts.append(
                    (min(round(max(self.room(true_deg)[0], 0.0) * 1000), 0x3FFF), offset_q3)
                )
            (d1, o1), (d2, o2) = parts
            body += struct.pack(
                "<HHB", (d1 << 2) | (o1 >> 4), (d2 << 2) | (o2 >> 4), (o1 & 0xF) | ((o2 & 0xF) << 4)
            )
        return body

    # --- on a serial line, in real time -------------------------------------------------

    def serve(self, line: SerialLine, stop: threading.Event) -> None:
        """Answer and stream on ``line`` in real time until ``stop`` is set."""
        writer = UartWriter(line.fd, self.spec.baud)
        while not stop.is_set():
            now = time.monotonic()
            heard = line.read_available()
            if self.frozen.is_set():  # hung: it stops scanning and hears nothing, and
                self.streaming = None  # comes back idle, to be asked again
                writer.free_at = 0.0
                stop.wait(0.005)
                continue
            answer = self.hear(heard, now) if heard else b""
            if answer:
                writer.send(answer, now)
            data, ready = self.stream_until(time.monotonic())
            if data:
                writer.send(data, ready)
            else:
                stop.wait(min(max(ready - time.monotonic(), 0.0005), 0.005))
