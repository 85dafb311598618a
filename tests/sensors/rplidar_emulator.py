"""A byte-exact RPLIDAR, written from Slamtec's protocol document (not from navd's driver):
it answers STOP, RESET, GET_HEALTH, GET_INFO, SCAN, EXPRESS_SCAN and SET_MOTOR_PWM as the
document says, and streams standard samples or express capsules of a room whose range is a
function of the (clockwise) angle."""

from __future__ import annotations

import struct
from collections.abc import Callable
from dataclasses import dataclass, field

SAMPLES_PER_TURN = 400
CAPSULES_PER_TURN = 12  # 32 samples each: 384 per turn


def descriptor(size: int, multiple: bool, kind: int) -> bytes:
    """The 7-byte answer descriptor: A5 5A, 30-bit size | 2-bit mode, data type."""
    return bytes([0xA5, 0x5A]) + struct.pack("<I", size | (int(multiple) << 30)) + bytes([kind])


def sample(angle_deg: float, distance_m: float, start: bool, quality: int = 47) -> bytes:
    """A standard-scan sample (5 bytes)."""
    angle_q6 = round(angle_deg * 64) & 0x7FFF
    flags = (quality << 2) | ((not start) << 1) | int(start)
    return bytes([flags, ((angle_q6 & 0x7F) << 1) | 1, angle_q6 >> 7]) + struct.pack(
        "<H", round(distance_m * 4000)
    )


def capsule(start_deg: float, new_scan: bool, samples: list[tuple[int, int]]) -> bytes:
    """An express capsule: 32 (distance [mm], dθ [1/8 deg, 6 bits]) samples."""
    body = struct.pack("<H", (round(start_deg * 64) & 0x7FFF) | (0x8000 if new_scan else 0))
    for j in range(16):
        (d1, o1), (d2, o2) = samples[2 * j], samples[2 * j + 1]
        o1, o2 = o1 & 0x3F, o2 & 0x3F
        body += struct.pack(
            "<HHB", (d1 << 2) | (o1 >> 4), (d2 << 2) | (o2 >> 4), (o1 & 0xF) | ((o2 & 0xF) << 4)
        )
    checksum = 0
    for byte in body:
        checksum ^= byte
    return bytes([0xA0 | (checksum & 0xF), 0x50 | (checksum >> 4)]) + body


@dataclass
class RplidarEmulator:
    """The device's side of the serial line.

    Args:
        room: [m] the range at a clockwise angle [deg] (0: no return).
        model: the GET_INFO model byte (0x18: an A1, 0x28: an A2).
        health: the GET_HEALTH status (0 good, 1 warning, 2 error) until a RESET.
    """

    room: Callable[[float], float]
    model: int = 0x28
    health: int = 0
    requests: list[int] = field(default_factory=list)
    pwm: list[int] = field(default_factory=list)
    streaming: str | None = None
    _pending: bytearray = field(default_factory=bytearray)
    _turn: int = 0

    def hear(self, data: bytes) -> bytes:
        """Take the host's bytes; the answers they ask for."""
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
                payload = b""
                del buf[:2]
            self.requests.append(cmd)
            out += self._answer(cmd, payload)
        return out

    def _answer(self, cmd: int, payload: bytes) -> bytes:
        if cmd == 0x25:  # STOP
            self.streaming = None
            return b""
        if cmd == 0x40:  # RESET: healthy again
            self.streaming, self.health = None, 0
            return b""
        if cmd == 0x52:  # GET_HEALTH
            return descriptor(3, False, 0x06) + struct.pack(
                "<BH", self.health, 0x8001 if self.health else 0
            )
        if cmd == 0x50:  # GET_INFO
            serial = bytes(range(16))
            return descriptor(20, False, 0x04) + bytes([self.model, 29, 1, 7]) + serial
        if cmd == 0xF0:  # SET_MOTOR_PWM
            self.pwm.append(struct.unpack("<H", payload)[0])
            return b""
        if cmd == 0x20:  # SCAN
            self.streaming = "standard"
            return descriptor(5, True, 0x81)
        if cmd == 0x82:  # EXPRESS_SCAN
            self.streaming = "express"
            return descriptor(84, True, 0x82)
        return b""

    def turn(self) -> bytes:
        """One turn of what is being streamed (nothing when stopped)."""
        first = self._turn == 0
        self._turn += 1
        if self.streaming == "standard":
            step = 360.0 / SAMPLES_PER_TURN
            return b"".join(
                sample(k * step, self.room(k * step), start=k == 0) for k in range(SAMPLES_PER_TURN)
            )
        if self.streaming == "express":
            span = 360.0 / CAPSULES_PER_TURN
            out = b""
            for c in range(CAPSULES_PER_TURN):
                start = c * span
                samples = []
                for k in range(32):
                    offset_q3 = (k % 8) * 8  # per-sample corrections 0 to 7 deg (6 bits, 1/8 deg)
                    true_deg = (start + k * span / 32 - offset_q3 / 8.0) % 360.0
                    samples.append((round(self.room(true_deg) * 1000), offset_q3))
                out += capsule(start, new_scan=first and c == 0, samples=samples)
            return out
        return b""
