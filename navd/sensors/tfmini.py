"""Benewake TFmini, TFmini-S, TFmini Plus and TF-Luna single-point lidars on a serial port:
a range sensor with a narrow beam (``navd sensor tfmini``).

Written from Benewake's product manuals: 115200 baud, 9-byte frames at 100 Hz by default:
``0x59 0x59``, the distance (u16, cm), the signal strength (u16), the chip temperature
(u16), and the low byte of the sum of the first eight bytes. A strength below
``MIN_STRENGTH`` or of 65535 (overexposed), or a distance of 0, is no reading: nothing within
reach. The frames of each ``PERIOD_S`` become one ``range`` frame with the nearest reading
among them (navd needs no more than 20 a second; the nearest is the one that matters).
"""

from __future__ import annotations

import struct
from dataclasses import dataclass, field

import serial

from navd.wire import RangeFrame, SensorFrame

__all__ = ["FRAME_BYTES", "Tfmini", "tfmini_frame"]

FRAME_BYTES = 9
HEADER = b"\x59\x59"
MIN_STRENGTH = 100
OVEREXPOSED = 65535
PERIOD_S = 0.05
FOV_RAD = 0.04  # [rad] the beam's full angle (2.3 deg)
RANGE_MIN_M = 0.1
RANGE_MAX_M = 8.0  # the TF-Luna's; the TFmini-S reaches 12 m (--range-max)


def tfmini_frame(distance_cm: int, strength: int, temperature_raw: int = 2000) -> bytes:
    """A frame as the device sends it (for tests)."""
    body = HEADER + struct.pack("<HHH", distance_cm, strength, temperature_raw)
    return body + bytes([sum(body) & 0xFF])


@dataclass
class Tfmini:
    """TFmini frames in, one ``range`` frame per ``PERIOD_S`` out.

    Args:
        range_max_m: [m] the model's reach.

    Attributes:
        skipped_bytes, bad_checksums: counts of bad input.
    """

    range_max_m: float = RANGE_MAX_M
    skipped_bytes: int = 0
    bad_checksums: int = 0
    _buffer: bytearray = field(default_factory=bytearray)
    _nearest_m: float | None = None
    _readings: int = 0
    _period_start: float | None = None

    def feed(self, data: bytes, stamp: float) -> list[SensorFrame]:
        """Take bytes read at ``stamp`` [s]; a range frame when a period is complete."""
        buffer = self._buffer
        buffer.extend(data)
        while True:
            start = buffer.find(HEADER)
            if start < 0:
                keep = 1 if buffer[-1:] == HEADER[:1] else 0
                self.skipped_bytes += len(buffer) - keep
                del buffer[: len(buffer) - keep]
                break
            if start:
                self.skipped_bytes += start
                del buffer[:start]
            if len(buffer) < FRAME_BYTES:
                break
            raw = bytes(buffer[:FRAME_BYTES])
            if sum(raw[:8]) & 0xFF != raw[8]:
                self.bad_checksums += 1
                self.skipped_bytes += 1
                del buffer[:1]
                continue
            del buffer[:FRAME_BYTES]
            distance_cm, strength, _ = struct.unpack_from("<HHH", raw, 2)
            self._reading(distance_cm, strength)
        if self._period_start is None:
            self._period_start = stamp
        if self._readings and stamp - self._period_start >= PERIOD_S:
            return [self._period(stamp)]
        return []

    def _reading(self, distance_cm: int, strength: int) -> None:
        self._readings += 1
        if distance_cm == 0 or strength < MIN_STRENGTH or strength == OVEREXPOSED:
            return
        distance = distance_cm / 100.0
        if self._nearest_m is None or distance < self._nearest_m:
            self._nearest_m = distance

    def _period(self, stamp: float) -> RangeFrame:
        nearest = self._nearest_m
        if nearest is not None and nearest > self.range_max_m:
            nearest = None
        frame = RangeFrame(
            stamp=self._period_start if self._period_start is not None else stamp,
            range=nearest,
            field_of_view=FOV_RAD,
            min_range=RANGE_MIN_M,
            max_range=self.range_max_m,
            radiation_type="infrared",
        )
        self._nearest_m, self._readings, self._period_start = None, 0, stamp
        return frame

    def counts(self) -> dict[str, int]:
        return {"skipped_bytes": self.skipped_bytes, "bad_checksums": self.bad_checksums}

    def opened(self, device: serial.Serial) -> None:
        """Nothing to start: it streams by itself."""

    def silent(self) -> None:
        """Nothing to ask again."""

    def closing(self, device: serial.Serial) -> None:
        """Nothing to stop."""

    def tick(self, now: float) -> None:
        """Nothing waits on the clock."""
