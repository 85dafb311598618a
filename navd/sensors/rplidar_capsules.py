"""RPLIDAR capsules: the 84-byte packets of the express (0x82) and dense (0x85) scans.

Both start with sync nibbles 0xA and 0x5 in the high halves of bytes 0-1, their low halves
the XOR checksum of bytes 2-83, then the start angle (bytes 2-3, q6 degrees, bit 15 set on a
capsule that begins a new scan). A capsule's samples lie between its start angle and the next
capsule's, so a capsule is decoded when the next one comes.

- Express: 16 cabins of two samples, each a 14-bit distance [mm] with the top two bits of a
  6-bit angle offset dθ [1/8 deg] below it, and a byte of the two offsets' low nibbles;
  sample k is at start + k (next - start) / 32 - dθ_k (dθ read unsigned, as Slamtec's SDK
  reads it).
- Dense: 40 distances [mm], u16 each; sample k at start + k (next - start) / 40.

A distance of 0 is no return.
"""

from __future__ import annotations

import struct

import numpy as np
import numpy.typing as npt

from navd.sensors.rplidar_protocol import CAPSULE_BYTES, Answer

__all__ = ["SAMPLES", "capsule_checksum", "capsule_points", "capsule_start", "capsule_synced"]

SAMPLES = {Answer.EXPRESS: 32, Answer.DENSE: 40}
_CABIN = struct.Struct("<HHB")
_DENSE = struct.Struct("<40H")

FloatArray = npt.NDArray[np.float64]


def capsule_checksum(capsule: bytes) -> int:
    """XOR of a capsule's bytes 2-83."""
    checksum = 0
    for byte in capsule[2:CAPSULE_BYTES]:
        checksum ^= byte
    return checksum


def capsule_synced(head: bytes) -> bool:
    """Whether bytes 0-1 carry the sync nibbles."""
    return head[0] >> 4 == 0xA and head[1] >> 4 == 0x5


def capsule_start(capsule: bytes) -> tuple[float, bool]:
    """[deg] the capsule's start angle, and whether it begins a new scan."""
    word = capsule[2] | (capsule[3] << 8)
    return (word & 0x7FFF) / 64.0, bool(word & 0x8000)


def capsule_points(
    kind: Answer, capsule: bytes, start_deg: float, next_deg: float
) -> tuple[FloatArray, FloatArray]:
    """[deg] clockwise angles and [m] ranges (NaN: no return) of a capsule's samples,
    given the next capsule's start angle."""
    count = SAMPLES[kind]
    step = ((next_deg - start_deg) % 360.0) / count
    angles = start_deg + step * np.arange(count)
    if kind is Answer.DENSE:
        distances_mm = np.array(_DENSE.unpack_from(capsule, 4), dtype=np.float64)
    else:
        distances_mm = np.empty(count)
        offsets = np.empty(count)
        for j in range(count // 2):
            first, second, nibbles = _CABIN.unpack_from(capsule, 4 + 5 * j)
            for k, (word, low) in enumerate(((first, nibbles & 0xF), (second, nibbles >> 4))):
                distances_mm[2 * j + k] = word >> 2
                offsets[2 * j + k] = ((word & 0x3) << 4) | low
        angles = angles - offsets / 8.0
    ranges = distances_mm / 1000.0
    ranges[distances_mm == 0] = np.nan
    return np.mod(angles, 360.0), ranges
