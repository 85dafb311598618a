"""A PNG picture of a map with a trajectory drawn on it (zlib only, no imaging library)."""

from __future__ import annotations

import struct
import zlib
from collections.abc import Iterable, Iterator
from pathlib import Path

import numpy as np
import numpy.typing as npt

from navd.geometry import Pose2
from navd.slam import OccupancyGrid

__all__ = ["encode_png", "encode_png_bands", "map_picture"]

TRAJECTORY_RGB = (220, 30, 30)
BAND_ROWS = 256  # rows converted and compressed at a time (a large map is not copied whole)


def encode_png(rgb: npt.NDArray[np.uint8], *, bottom_up: bool = False) -> bytes:
    """An 8-bit RGB PNG of ``rgb`` (rows x cols x 3, top row first; last row first if
    ``bottom_up``, as a map's row 0 is its bottom)."""
    rows, cols, _ = rgb.shape
    if bottom_up:
        tops = range(rows, 0, -BAND_ROWS)
        bands = (rgb[max(top - BAND_ROWS, 0) : top][::-1] for top in tops)
    else:
        bands = (rgb[start : start + BAND_ROWS] for start in range(0, rows, BAND_ROWS))
    return encode_png_bands(rows, cols, bands)


def encode_png_bands(rows: int, cols: int, bands: Iterable[npt.NDArray[np.uint8]]) -> bytes:
    """An 8-bit RGB PNG of ``rows`` x ``cols`` pixels given as ``bands`` of rows (each
    n x cols x 3, top band first): a large picture is never held whole."""

    def chunk(kind: bytes, data: bytes) -> bytes:
        crc = zlib.crc32(kind + data) & 0xFFFFFFFF
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", crc)

    deflate = zlib.compressobj(6)
    parts = []
    seen = 0
    for band in bands:
        # Each row starts with filter type 0 (none).
        flat = band.reshape(band.shape[0], cols * 3)
        raw = np.hstack([np.zeros((band.shape[0], 1), dtype=np.uint8), flat])
        parts.append(deflate.compress(raw.tobytes()))
        seen += band.shape[0]
    if seen != rows:
        raise ValueError(f"a PNG of {rows} rows was given {seen}")
    parts.append(deflate.flush())
    header = struct.pack(">IIBBBBB", cols, rows, 8, 2, 0, 0, 0)
    return (
        b"\x89PNG\r\n\x1a\n"
        + chunk(b"IHDR", header)
        + chunk(b"IDAT", b"".join(parts))
        + chunk(b"IEND", b"")
    )


def map_picture(grid: OccupancyGrid, trajectory: list[Pose2], path: Path) -> None:
    """Write the map (white free, black occupied, grey unknown) with the trajectory in red,
    a band of rows at a time (fr-clinic's picture is 123 MB of pixels)."""
    rows, cols = grid.shape
    cells = np.zeros((0, 2), dtype=np.int64)
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
        inside = (
            (cells[:, 0] >= 0) & (cells[:, 0] < cols) & (cells[:, 1] >= 0) & (cells[:, 1] < rows)
        )
        cells = cells[inside]

    def bands() -> Iterator[npt.NDArray[np.uint8]]:
        for top in range(rows, 0, -BAND_ROWS):  # the map's top (its last rows) first
            bottom = max(top - BAND_ROWS, 0)
            band = grid.occupancy_percent(slice(bottom, top)).astype(np.int16)
            gray = np.where(band < 0, 205, 255 - band * 255 // 100).astype(np.uint8)
            rgb = np.repeat(gray[:, :, None], 3, axis=2)
            mine = cells[(cells[:, 1] >= bottom) & (cells[:, 1] < top)]
            rgb[mine[:, 1] - bottom, mine[:, 0]] = TRAJECTORY_RGB
            yield rgb[::-1]

    path.write_bytes(encode_png_bands(rows, cols, bands()))
