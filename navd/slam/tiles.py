"""A large float32 array kept as square tiles, allocated only where something was written.

A building's map is mostly space the robot never saw: fr-clinic's grid is 244 x 432 m at
5 cm (41 million cells, 162 MB dense), but the lidar touched 28 % of its 64 x 64 tiles. The
grid's kernels read and write through the tile index (see ``_grid_kernels``); a tile never
written reads as 0 (unknown) and costs nothing but its index entry.

Cell (row, col) of the array lives in tile ``index[(row + off_r) >> TILE_SHIFT,
(col + off_c) >> TILE_SHIFT]`` at ``((row + off_r) & TILE_MASK, (col + off_c) & TILE_MASK)``.
The offsets let the array grow at its low edges by any number of cells without moving a
tile: growing by a whole tile adds index rows or columns, never copies cells.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt

__all__ = ["TILE", "TILE_MASK", "TILE_SHIFT", "TiledArray"]

F32 = npt.NDArray[np.float32]
I32 = npt.NDArray[np.int32]
I64 = npt.NDArray[np.int64]
TILE_SHIFT = 6
TILE = 1 << TILE_SHIFT  # cells per tile side
TILE_MASK = TILE - 1
MIN_CAPACITY = 16  # tiles reserved at least when the store first grows


def _tiles_for(cells: int) -> int:
    """Tiles needed to hold ``cells`` cells from a tile boundary."""
    return -(-cells // TILE)


class TiledArray:
    """A [rows, cols] float32 array, zero where never written, stored in TILE x TILE tiles.

    The parts the kernels take, in this order (``parts()``): ``index`` (int32 [tile rows,
    tile cols], -1 where no tile is allocated), ``tiles`` (float32 [capacity, TILE, TILE]),
    ``used`` (int64 [1], tiles allocated; a kernel allocates the next one on a write into an
    empty tile, so callers ``reserve`` capacity first), ``off_r``, ``off_c``, ``rows``, ``cols``.
    """

    def __init__(self, rows: int = 0, cols: int = 0) -> None:
        self.rows, self.cols = rows, cols
        self.off_r = self.off_c = 0
        self.index = np.full((_tiles_for(rows), _tiles_for(cols)), -1, dtype=np.int32)
        self.tiles: F32 = np.zeros((0, TILE, TILE), dtype=np.float32)
        self.used = np.zeros(1, dtype=np.int64)

    @classmethod
    def from_dense(cls, array: npt.ArrayLike) -> TiledArray:
        """The tiles of ``array`` (2-D, copied as float32); all-zero tiles are not stored."""
        dense = np.asarray(array, dtype=np.float32)
        if dense.ndim != 2:
            raise ValueError(f"a grid is 2-D, not of shape {dense.shape}")
        rows, cols = dense.shape
        out = cls(rows, cols)
        tr, tc = out.index.shape
        kept = [np.zeros((0, TILE, TILE), dtype=np.float32)]
        count = 0
        # A row of tiles at a time: a large map is never copied whole.
        for r in range(tr):
            band = np.zeros((TILE, tc * TILE), dtype=np.float32)
            part = dense[r * TILE : (r + 1) * TILE]
            band[: part.shape[0], :cols] = part
            blocks = band.reshape(TILE, tc, TILE).swapaxes(0, 1)
            written = blocks.any(axis=(1, 2))
            n = int(written.sum())
            out.index[r, written] = np.arange(count, count + n, dtype=np.int32)
            kept.append(blocks[written])
            count += n
        out.tiles = np.ascontiguousarray(np.concatenate(kept))
        out.used[0] = out.tiles.shape[0]
        return out

    @classmethod
    def from_parts(
        cls, index: npt.ArrayLike, tiles: npt.ArrayLike, offset: npt.ArrayLike, shape: npt.ArrayLike
    ) -> TiledArray:
        """The array ``state()`` gave these parts of, checked.

        Raises:
            ValueError: parts that no ``state()`` writes, named.
        """
        idx = np.asarray(index)
        t = np.asarray(tiles)
        off = np.asarray(offset)
        extent = np.asarray(shape)
        for name, part in (("tile_offset", off), ("shape", extent), ("tile_index", idx)):
            if not np.issubdtype(part.dtype, np.integer):
                raise ValueError(f"{name} holds {part.dtype}, not integers")
        if off.shape != (2,) or (off < 0).any() or (off >= TILE).any():
            raise ValueError(f"tile_offset {off.tolist()} is not two cells within one tile")
        if extent.shape != (2,) or (extent < 0).any():
            raise ValueError(f"shape {extent.tolist()} is not two sizes")
        if t.ndim != 3 or t.shape[1:] != (TILE, TILE) or t.dtype != np.float32:
            raise ValueError(
                f"tiles of shape {t.shape} ({t.dtype}), not N x {TILE} x {TILE} float32"
            )
        out = cls()
        out.rows, out.cols = int(extent[0]), int(extent[1])
        out.off_r, out.off_c = int(off[0]), int(off[1])
        need = (_tiles_for(out.rows + out.off_r), _tiles_for(out.cols + out.off_c))
        if idx.shape != need:
            raise ValueError(f"a tile index of shape {idx.shape}, not the {need} tiles it needs")
        named = idx[idx >= 0]
        if (idx < -1).any() or (named >= t.shape[0]).any():
            raise ValueError(f"the tile index names tiles outside the {t.shape[0]} stored")
        if np.unique(named).size != named.size:
            raise ValueError("the tile index names one tile for two places")
        out.index = idx.astype(np.int32)
        # C order, as the kernels index it (a file may hold the tiles Fortran-ordered)
        out.tiles = np.ascontiguousarray(t, dtype=np.float32)
        out.used[0] = t.shape[0]
        return out

    def state(self) -> dict[str, Any]:
        """The arrays that make this array again exactly (``from_parts``)."""
        return {
            "tile_index": self.index,
            "tiles": self.tiles[: int(self.used[0])],
            "tile_offset": np.array([self.off_r, self.off_c]),
            "shape": np.array([self.rows, self.cols]),
        }

    def copy(self) -> TiledArray:
        """A deep copy holding only the allocated tiles."""
        out = TiledArray()
        out.rows, out.cols, out.off_r, out.off_c = self.rows, self.cols, self.off_r, self.off_c
        out.index = self.index.copy()
        out.tiles = self.tiles[: int(self.used[0])].copy()
        out.used[0] = self.used[0]
        return out

    @property
    def allocated_bytes(self) -> int:
        """Bytes of the tiles written so far (the capacity beyond is never touched)."""
        return int(self.used[0]) * TILE * TILE * 4

    def parts(self) -> tuple[I32, F32, I64, int, int, int, int]:
        """What the tiled kernels take: index, tiles, used, off_r, off_c, rows, cols."""
        return (self.index, self.tiles, self.used, self.off_r, self.off_c, self.rows, self.cols)

    def window(self, r0: int, r1: int, c0: int, c1: int) -> F32:
        """A dense copy of rows [r0, r1) and columns [c0, c1), clipped to the array."""
        r0, r1 = max(r0, 0), min(r1, self.rows)
        c0, c1 = max(c0, 0), min(c1, self.cols)
        out = np.zeros((max(r1 - r0, 0), max(c1 - c0, 0)), dtype=np.float32)
        if out.size == 0:
            return out
        g0, g1 = r0 + self.off_r, r1 + self.off_r  # in the tiles' own cell numbering
        h0, h1 = c0 + self.off_c, c1 + self.off_c
        for tr in range(g0 >> TILE_SHIFT, ((g1 - 1) >> TILE_SHIFT) + 1):
            for tc in range(h0 >> TILE_SHIFT, ((h1 - 1) >> TILE_SHIFT) + 1):
                t = self.index[tr, tc]
                if t < 0:
                    continue
                y0, y1 = max(g0, tr * TILE), min(g1, (tr + 1) * TILE)
                x0, x1 = max(h0, tc * TILE), min(h1, (tc + 1) * TILE)
                out[y0 - g0 : y1 - g0, x0 - h0 : x1 - h0] = self.tiles[
                    t, y0 - tr * TILE : y1 - tr * TILE, x0 - tc * TILE : x1 - tc * TILE
                ]
        return out

    def grow(self, rows: int, cols: int, shift_r: int, shift_c: int) -> None:
        """Become [rows, cols], the old cell (r, c) now at (r + shift_r, c + shift_c); the
        new cells are 0. Tiles never move: only the index gains rows and columns."""
        if shift_r < 0 or shift_c < 0 or rows < self.rows + shift_r or cols < self.cols + shift_c:
            raise ValueError("a tiled array only grows")
        off_r, off_c = self.off_r - shift_r, self.off_c - shift_c
        pre_r = _tiles_for(-off_r) if off_r < 0 else 0
        pre_c = _tiles_for(-off_c) if off_c < 0 else 0
        off_r += pre_r * TILE
        off_c += pre_c * TILE
        tr, tc = _tiles_for(rows + off_r), _tiles_for(cols + off_c)
        if (pre_r, pre_c, tr, tc) != (0, 0, *self.index.shape):
            index = np.full((tr, tc), -1, dtype=np.int32)
            h, w = self.index.shape
            index[pre_r : pre_r + h, pre_c : pre_c + w] = self.index
            self.index = index
        self.rows, self.cols, self.off_r, self.off_c = rows, cols, off_r, off_c

    def reserve(self, r0: int, r1: int, c0: int, c1: int) -> None:
        """Make room for a tile in every empty place that rows [r0, r1] and columns [c0, c1]
        (inclusive, clipped to the array) touch, so a kernel writing there can allocate."""
        r0, r1 = max(r0, 0), min(r1, self.rows - 1)
        c0, c1 = max(c0, 0), min(c1, self.cols - 1)
        if r0 > r1 or c0 > c1:
            return
        block = self.index[
            (r0 + self.off_r) >> TILE_SHIFT : ((r1 + self.off_r) >> TILE_SHIFT) + 1,
            (c0 + self.off_c) >> TILE_SHIFT : ((c1 + self.off_c) >> TILE_SHIFT) + 1,
        ]
        need = int(self.used[0]) + int(np.count_nonzero(block < 0))
        capacity = self.tiles.shape[0]
        if need > capacity:
            # np.zeros leaves the pages past what is copied untouched: they cost no memory
            # until a tile is written there.
            grown = np.zeros((max(need, 2 * capacity, MIN_CAPACITY), TILE, TILE), np.float32)
            grown[: int(self.used[0])] = self.tiles[: int(self.used[0])]
            self.tiles = grown
