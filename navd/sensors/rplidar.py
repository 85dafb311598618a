"""Slamtec RPLIDAR A1/A2/A3/C1/S1 on a serial port: requests, responses, and turns as scans.

Written from Slamtec's "RPLIDAR Interface Protocol and Application Notes". A request is
``0xA5 cmd`` with, for commands that take one, a payload size, the payload and an XOR
checksum of every byte before it. An answer starts with a 7-byte descriptor: ``0xA5 0x5A``,
a 30-bit length and 2-bit send mode (little-endian), and a data type.

========== ===== =============================================================
request    cmd   answer
========== ===== =============================================================
STOP       0x25  none; the lidar stops sending
RESET      0x40  none; the core restarts (after a health error)
GET_HEALTH 0x52  type 0x06, 3 bytes: status (0 good, 1 warning, 2 error), error u16
GET_INFO   0x50  type 0x04, 20 bytes: model, firmware minor, major, hardware, serial[16]
SCAN       0x20  type 0x81, then 5-byte samples until STOP (standard scan)
EXPRESS    0x82  type 0x82, then 84-byte capsules until STOP (legacy express scan)
MOTOR_PWM  0xF0  none; the A2/A3 motor duty (0-1023; 0 stops it)
========== ===== =============================================================

A standard sample: byte 0 is quality << 2 | !S << 1 | S (S: the first sample of a new
turn), byte 1 is angle_q6[6:0] << 1 | 1, byte 2 angle_q6[14:7], bytes 3-4 the distance in
quarter millimetres; a sample whose check bits are wrong is skipped a byte at a time.

An express capsule: sync nibbles 0xA and 0x5 in the high halves of bytes 0-1, their low
halves the XOR checksum of bytes 2-83; bytes 2-3 the start angle (q6, bit 15 the new-scan
flag); then 16 cabins of two samples, each a 14-bit distance [mm] with the top two bits of
a 6-bit angle offset dθ [1/8 deg] below it, and a byte of the two offsets' low nibbles. A
capsule's 32 samples lie between its start angle and the next capsule's: sample k is at
start + k (next - start) / 32 - dθ_k, so a capsule is decoded when the next one comes. dθ is
read as Slamtec's own SDK reads it, unsigned (0 to 63/8 deg).

Angles grow clockwise from the lidar's front; a distance of 0 is no return. The A1's motor
runs while the serial adapter's DTR line is low; the A2 and A3 take a PWM duty; the C1 and
S1 spin by themselves. One turn becomes one ScanFrame (``turns.turn_scan``).
"""

from __future__ import annotations

import enum
import math
import struct
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from navd.sensors.revolution_scan import turn_scan
from navd.wire import ScanFrame, SensorFrame

__all__ = [
    "CAPSULE_BYTES",
    "Command",
    "RplidarDecoder",
    "RplidarInfo",
    "ScanMode",
    "capsule_checksum",
    "request",
]

SYNC = 0xA5
ANSWER = 0x5A
DESCRIPTOR_BYTES = 7
SAMPLE_BYTES = 5
CAPSULE_BYTES = 84
CABINS = 16
DEFAULT_PWM = 660  # the A2/A3 motor duty Slamtec's SDK starts with
RANGE_MIN_M = 0.15
RANGE_MAX_M = 12.0
SCAN_BINS = 720  # 0.5 deg: finer than any model's spacing at 10 Hz


class Command(enum.IntEnum):
    """Request bytes (see the module docstring)."""

    STOP = 0x25
    RESET = 0x40
    SCAN = 0x20
    EXPRESS_SCAN = 0x82
    GET_INFO = 0x50
    GET_HEALTH = 0x52
    SET_MOTOR_PWM = 0xF0


class Answer(enum.IntEnum):
    """Descriptor data types."""

    INFO = 0x04
    HEALTH = 0x06
    SCAN = 0x81
    EXPRESS = 0x82


class ScanMode(enum.Enum):
    """Which scan the lidar is asked for."""

    STANDARD = "standard"
    EXPRESS = "express"


def request(command: Command, payload: bytes | None = None) -> bytes:
    """The bytes of a request, with its size and checksum when it has a payload."""
    if payload is None:
        return bytes([SYNC, command])
    body = bytes([SYNC, command, len(payload)]) + payload
    checksum = 0
    for byte in body:
        checksum ^= byte
    return body + bytes([checksum])


def capsule_checksum(capsule: bytes) -> int:
    """XOR of an express capsule's bytes 2-83."""
    checksum = 0
    for byte in capsule[2:CAPSULE_BYTES]:
        checksum ^= byte
    return checksum


@dataclass(frozen=True, slots=True)
class RplidarInfo:
    """What GET_INFO says: the model byte, firmware and hardware versions, serial number."""

    model: int
    firmware: str
    hardware: int
    serial: str

    @property
    def series(self) -> str:
        """ "A1", "A2", "A3" by the model byte's high nibble; else the byte itself."""
        return {1: "A1", 2: "A2", 3: "A3"}.get(self.model >> 4, f"model 0x{self.model:02X}")


_DESCRIPTOR = struct.Struct("<BBIB")
_SAMPLE = struct.Struct("<BBBH")
_CABIN = struct.Struct("<HHB")


@dataclass
class RplidarDecoder:
    """Talks to one RPLIDAR: asks its health and info, starts its motor and scan, and turns
    the samples into one ScanFrame per turn.

    Args:
        mode: standard or express scan.
        notes: told what the lidar says of itself (its info, a health warning), for the log.

    Attributes:
        skipped_bytes, bad_checksums, health_errors: counts of bad input.
        info: what the lidar said it is, once it has.
    """

    mode: ScanMode = ScanMode.STANDARD
    notes: Callable[[str, dict[str, object]], None] = lambda event, fields: None
    skipped_bytes: int = 0
    bad_checksums: int = 0
    health_errors: int = 0
    info: RplidarInfo | None = None
    _write: Callable[[bytes], None] = lambda data: None
    _buffer: bytearray = field(default_factory=bytearray)
    _stream: Answer | None = None  # the multi-answer being streamed, if any
    _capsule: tuple[float, bytes] | None = None  # the last express capsule, awaiting the next
    _angles: list[float] = field(default_factory=list)
    _ranges: list[float] = field(default_factory=list)
    _turn_stamp: float = 0.0

    # --- the device's side --------------------------------------------------------------

    def opened(self, write: Callable[[bytes], None], set_dtr: Callable[[bool], None]) -> None:
        """The port is open: start the A1's motor (DTR low), stop any scan, ask its health."""
        self._write = write
        set_dtr(False)
        self.restart()

    def restart(self) -> None:
        """Start over (a device that fell silent mid-scan): stop, then ask its health."""
        self._send(request(Command.STOP))
        self._send(request(Command.GET_HEALTH))

    def closing(self, set_dtr: Callable[[bool], None]) -> None:
        """Stop the scan and the motor before the port closes."""
        self._send(request(Command.STOP))
        if self.info is not None and self.info.series in ("A2", "A3"):
            self._send(request(Command.SET_MOTOR_PWM, struct.pack("<H", 0)))
        set_dtr(True)

    def _send(self, data: bytes) -> None:
        # A new request ends what was being streamed: the next bytes answer it.
        self._stream = None
        self._capsule = None
        self._buffer.clear()
        self._write(data)

    # --- bytes in, frames out -----------------------------------------------------------

    def feed(self, data: bytes, stamp: float) -> list[SensorFrame]:
        """Take bytes read at ``stamp`` [s]; the turns they completed."""
        self._buffer.extend(data)
        frames: list[SensorFrame] = []
        while True:
            if self._stream is None:
                if not self._descriptor():
                    return frames
            elif self._stream is Answer.SCAN:
                if not self._sample(stamp, frames):
                    return frames
            elif not self._express(stamp, frames):
                return frames

    def counts(self) -> dict[str, int]:
        return {
            "skipped_bytes": self.skipped_bytes,
            "bad_checksums": self.bad_checksums,
            "health_errors": self.health_errors,
        }

    def _skip(self, count: int) -> None:
        self.skipped_bytes += count
        del self._buffer[:count]

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
        if multiple and kind in (Answer.SCAN, Answer.EXPRESS):
            del buffer[:DESCRIPTOR_BYTES]
            self._stream = Answer(kind)
            return True
        if len(buffer) < DESCRIPTOR_BYTES + size:
            return False
        body = bytes(buffer[DESCRIPTOR_BYTES : DESCRIPTOR_BYTES + size])
        del buffer[: DESCRIPTOR_BYTES + size]
        if kind == Answer.HEALTH and size == 3:
            self._health(body)
        elif kind == Answer.INFO and size == 20:
            self._info(body)
        else:
            self.skipped_bytes += DESCRIPTOR_BYTES + size  # an answer not asked for
        return True

    def _health(self, body: bytes) -> None:
        status, error = struct.unpack("<BH", body)
        if status == 2:
            self.health_errors += 1
            self.notes("lidar_health_error", {"error_code": error})
            self._send(request(Command.RESET))  # the protocol's remedy; asked again when silent
            return
        if status == 1:
            self.notes("lidar_health_warning", {"error_code": error})
        self._send(request(Command.GET_INFO))

    def _info(self, body: bytes) -> None:
        model, minor, major, hardware = body[:4]
        self.info = RplidarInfo(model, f"{major}.{minor:02d}", hardware, body[4:20].hex().upper())
        self.notes(
            "lidar_info",
            {
                "series": self.info.series,
                "firmware": self.info.firmware,
                "serial": self.info.serial,
            },
        )
        if self.info.series in ("A2", "A3"):
            self._send(request(Command.SET_MOTOR_PWM, struct.pack("<H", DEFAULT_PWM)))
        if self.mode is ScanMode.EXPRESS:
            # legacy express scan: working mode 0 and four reserved bytes
            self._send(request(Command.EXPRESS_SCAN, bytes(5)))
        else:
            self._send(request(Command.SCAN))

    def _sample(self, stamp: float, frames: list[SensorFrame]) -> bool:
        buffer = self._buffer
        if len(buffer) < SAMPLE_BYTES:
            return False
        flags, low, high, distance_q2 = _SAMPLE.unpack_from(buffer)
        start, inverse, check = flags & 1, (flags >> 1) & 1, low & 1
        if start == inverse or not check:
            self._skip(1)  # out of step: find the next sample boundary
            return True
        del buffer[:SAMPLE_BYTES]
        angle = ((high << 7) | (low >> 1)) / 64.0
        if start:
            self._end_turn(stamp, frames)
        distance = distance_q2 / 4000.0
        self._point(angle, distance if distance > 0.0 and flags >> 2 else math.nan, stamp)
        return True

    def _express(self, stamp: float, frames: list[SensorFrame]) -> bool:
        buffer = self._buffer
        if len(buffer) < CAPSULE_BYTES:
            return False
        if buffer[0] >> 4 != 0xA or buffer[1] >> 4 != 0x5:
            self._skip(1)
            return True
        capsule = bytes(buffer[:CAPSULE_BYTES])
        if (capsule[0] & 0xF) | ((capsule[1] & 0xF) << 4) != capsule_checksum(capsule):
            self.bad_checksums += 1
            self._skip(1)
            return True
        del buffer[:CAPSULE_BYTES]
        word = capsule[2] | (capsule[3] << 8)
        start_deg = (word & 0x7FFF) / 64.0
        if word & 0x8000:  # a new scan began: the capsule before belongs to no turn
            self._capsule = None
            self._end_turn(stamp, frames)
        if self._capsule is not None:
            previous_deg, previous = self._capsule
            self._capsule_points(previous_deg, previous, start_deg, stamp)
            if start_deg < previous_deg:
                # the capsules' start angles passed the front: the turn is complete (its
                # samples near 0 deg may read a little below, as 359; they are this turn's)
                self._end_turn(stamp, frames)
        self._capsule = (start_deg, capsule)
        return True

    def _capsule_points(
        self, start_deg: float, capsule: bytes, next_deg: float, stamp: float
    ) -> None:
        step = ((next_deg - start_deg) % 360.0) / (2 * CABINS)
        for j in range(CABINS):
            first, second, nibbles = _CABIN.unpack_from(capsule, 4 + 5 * j)
            for k, (word, low) in enumerate(((first, nibbles & 0xF), (second, nibbles >> 4))):
                offset = ((word & 0x3) << 4) | low  # unsigned, as the maker's SDK reads it
                angle = (start_deg + step * (2 * j + k) - offset / 8.0) % 360.0
                distance = (word >> 2) / 1000.0
                self._point(angle, distance if distance > 0.0 else math.nan, stamp)

    def _point(self, angle_deg: float, range_m: float, stamp: float) -> None:
        if not self._angles:
            self._turn_stamp = stamp
        self._angles.append(angle_deg)
        self._ranges.append(range_m)

    def _end_turn(self, stamp: float, frames: list[SensorFrame]) -> None:
        if len(self._angles) >= 2:
            scan = self._scan()
            if scan is not None:
                frames.append(scan)
        self._angles.clear()
        self._ranges.clear()
        self._turn_stamp = stamp

    def _scan(self) -> ScanFrame | None:
        angles: npt.NDArray[np.float64] = np.array(self._angles)
        ranges: npt.NDArray[np.float64] = np.array(self._ranges)
        return turn_scan(
            angles,
            ranges,
            stamp=self._turn_stamp,
            bins=SCAN_BINS,
            range_min_m=RANGE_MIN_M,
            range_max_m=RANGE_MAX_M,
        )
