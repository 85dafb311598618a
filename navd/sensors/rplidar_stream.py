"""A running RPLIDAR scan's bytes as points in time, grouped into turns: standard samples
(5 bytes each, with their quality) or capsules (express or dense, 84 bytes each).

A standard sample whose check bits are wrong is skipped a byte at a time; a capsule whose
checksum fails is dropped and counted. Each sample is placed in time by when its bytes
arrived (the read's time less the line time of the bytes after it). A capsule holds the
samples measured before it was sent, spread over the mode's time per sample, and is decoded
as it arrives: its samples lie between its start angle and the next capsule's, foreseen by
the step between the last two (the motor turns steadily; waiting for the next capsule would
hold each turn back by one). Standard samples end a turn at their start flag; capsules where
the angle passes the front (``turn_builder``).
"""

from __future__ import annotations

import math
import struct

import numpy as np

from navd.sensors.rplidar_capsules import (
    SAMPLES,
    capsule_checksum,
    capsule_points,
    capsule_start,
    capsule_synced,
)
from navd.sensors.rplidar_protocol import CAPSULE_BYTES, SAMPLE_BYTES, Answer
from navd.sensors.turn_builder import TurnBuilder
from navd.wire import ScanFrame

__all__ = ["ScanStream", "StreamCounts"]

_SAMPLE = struct.Struct("<BBBH")


class StreamCounts:
    """Bad input summed over every stream a decoder has read."""

    def __init__(self) -> None:
        self._streams: list[ScanStream] = []
        self._ended = (0, 0)

    def add(self, stream: ScanStream) -> None:
        """Count ``stream`` too (the one before it is over: its counts are kept)."""
        for old in self._streams:
            skipped, bad = self._ended
            self._ended = (skipped + old.skipped_bytes, bad + old.bad_checksums)
        self._streams = [stream]

    @property
    def skipped_bytes(self) -> int:
        return self._ended[0] + sum(s.skipped_bytes for s in self._streams)

    @property
    def bad_checksums(self) -> int:
        return self._ended[1] + sum(s.bad_checksums for s in self._streams)


class ScanStream:
    """One scan's stream, from its descriptor on.

    Args:
        kind: the answer type its samples come in.
        byte_s: [s] a byte's time on the line.
        turns: where its points go.
        us_per_sample: [µs] the mode's time per sample (0: not known, then the time between
            two capsules' arrivals).
    """

    def __init__(
        self, kind: Answer, byte_s: float, turns: TurnBuilder, us_per_sample: float
    ) -> None:
        self.kind = kind
        self.byte_s = byte_s
        self.turns = turns
        self.us_per_sample = us_per_sample
        self.skipped_bytes = 0
        self.bad_checksums = 0
        self._capsule: tuple[float, float] | None = None  # start [deg], arrival [s]
        self._step = 0.0  # [deg] between two capsules' start angles

    def take(self, buffer: bytearray, read_s: float) -> list[ScanFrame]:
        """Consume what ``buffer`` holds of the stream (read at ``read_s``); the turns
        it completed."""
        frames: list[ScanFrame] = []
        unit = self._sample if self.kind is Answer.SCAN else self._capsule_in
        while unit(buffer, read_s, frames):
            pass
        return frames

    def _sample(self, buffer: bytearray, read_s: float, frames: list[ScanFrame]) -> bool:
        if len(buffer) < SAMPLE_BYTES:
            return False
        flags, low, high, distance_q2 = _SAMPLE.unpack_from(buffer)
        start, inverse, check = flags & 1, (flags >> 1) & 1, low & 1
        if start == inverse or not check:
            self.skipped_bytes += 1  # out of step: find the next sample boundary
            del buffer[:1]
            return True
        del buffer[:SAMPLE_BYTES]
        at = read_s - (len(buffer) + SAMPLE_BYTES) * self.byte_s
        if start:
            scan = self.turns.end_turn()
            if scan is not None:
                frames.append(scan)
        quality = flags >> 2
        distance = distance_q2 / 4000.0
        frames.extend(
            self.turns.add(
                np.array([((high << 7) | (low >> 1)) / 64.0]),
                np.array([distance if distance > 0.0 and quality else math.nan]),
                np.array([at]),
                np.array([float(quality)]),
            )
        )
        return True

    def _capsule_in(self, buffer: bytearray, read_s: float, frames: list[ScanFrame]) -> bool:
        if len(buffer) < CAPSULE_BYTES:
            return False
        capsule = bytes(buffer[:CAPSULE_BYTES])
        if not capsule_synced(capsule):
            self.skipped_bytes += 1
            del buffer[:1]
            return True
        if (capsule[0] & 0xF) | ((capsule[1] & 0xF) << 4) != capsule_checksum(capsule):
            self.bad_checksums += 1
            self.skipped_bytes += 1
            del buffer[:1]
            return True
        del buffer[:CAPSULE_BYTES]
        arrived = read_s - len(buffer) * self.byte_s
        start_deg, new_scan = capsule_start(capsule)
        if new_scan:  # a new scan began: what came before belongs to no turn
            self._capsule = None
            self.turns.clear()
        if self._capsule is not None:
            previous_deg, previous_at = self._capsule
            step = (start_deg - previous_deg) % 360.0
            if self._step and abs(step - self._step) > 0.5 * self._step:
                step = self._step  # a capsule between was lost: keep the known step
            self._step = step
            count = SAMPLES[self.kind]
            span = (
                count * self.us_per_sample * 1e-6
                if self.us_per_sample > 0
                else max(arrived - previous_at, 0.0)
            )
            # measured before the capsule was sent: its last sample as its bytes began
            sent = arrived - CAPSULE_BYTES * self.byte_s
            times = sent - span * (count - 1 - np.arange(count)) / count
            angles, ranges = capsule_points(self.kind, capsule, start_deg, start_deg + step)
            frames.extend(self.turns.add(angles, ranges, times))
        self._capsule = (start_deg, arrived)
        return True
