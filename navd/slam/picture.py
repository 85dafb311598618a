"""A PNG picture of a map with a trajectory drawn on it (zlib only, no imaging library)."""

from __future__ import annotations

import struct
import zlib
from pathlib import Path

import numpy as np
import numpy.typing as npt

from navd.geometry.pose import Pose2
from navd.slam.occupancy import OccupancyGrid

__all__ = ["encode_png", "map_picture"]

TRAJECTORY_RGB = (220, 30, 30)
BAND_ROWS = 256  # rows converted and compressed at a time (a large map is not copied whole)


def encode_png(rgb: npt.NDArray[np.uint8], *, bottom_up: bool = False) -> bytes:
    """An 8-bit RGB PNG of ``rgb`` (rows x cols x 3, top row first; last row first if
    ``bottom_up``, as a map's row 0 is its bottom)."""
    rows, cols, _ = rgb.shape

    def chunk(kind: bytes, data: bytes) -> bytes:
        crc = zlib.crc32(kind + data) & 0xFFFFFFFF
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", crc)

    deflate = zlib.compressobj(6)
    parts = []
    for start in range(0, rows, BAND_ROWS):
        if bottom_up:
            band = rgb[max(rows - start - BAND_ROWS, 0) : rows - start][::-1]
        else:
            band = rgb[start : start + BAND_ROWS]
        # Each row starts with filter type 0 (none).
        flat = band.reshape(band.shape[0], cols * 3)
        raw = np.hstack([np.zeros((band.shape[0], 1), dtype=np.uint8), flat])
        parts.append(deflate.compress(raw.tobytes()))
    parts.append(deflate.flush())
    header = struct.pack(">IIBBBBB", cols, rows, 8, 2, 0, 0, 0)
    return (
        b"\x89PNG\r\n\x1a\n"
        + chunk(b"IHDR", header)
        + chunk(b"IDAT", b"".join(parts))
        + chunk(b"IEND", b"")
    )


def map_picture(grid: OccupancyGrid, trajectory: list[Pose2], path: Path) -> None:
    """Write the map (white free, black occupied, grey unknown) with the trajectory in red."""
    occupancy = grid.occupancy_percent()
    rgb = np.empty((*occupancy.shape, 3), dtype=np.uint8)
    for start in range(0, occupancy.shape[0], BAND_ROWS):
        band = occupancy[start : start + BAND_ROWS].astype(np.int16)
        gray = np.where(band < 0, 205, 255 - band * 255 // 100).astype(np.uint8)
        rgb[start : start + BAND_ROWS] = gray[:, :, None]
    del occupancy
    if len(trajectory) > 1:
        xy = np.array([(p.x, p.y) for p in trajectory])
        # Sample the path every half cell so the drawn line has no gaps.
        steps = np.maximum(
            1, np.ceil(np.linalg.norm(np.diff(xy, axis=0), axis=1) / (grid.resolution / 2))
        ).astype(int)
        dense = np.vstack(
            [
                np.linspace(a, b, n, endpoint=False)
                for a, b, n in zip(xy[:-1], xy[1:], steps, strict=True)
            ]
            + [xy[-1:]]
        )
        cells = grid.cells(dense)
        rows, cols = rgb.shape[:2]
        inside = (
            (cells[:, 0] >= 0) & (cells[:, 0] < cols) & (cells[:, 1] >= 0) & (cells[:, 1] < rows)
        )
        rgb[cells[inside, 1], cells[inside, 0]] = TRAJECTORY_RGB
    path.write_bytes(encode_png(rgb, bottom_up=True))
