"""The occupancy grid: log-odds by ray casting, growing as the robot explores.

Cell (col, row) covers x in [origin_x + col * res, origin_x + (col + 1) * res) and likewise
for y. A log-odds of exactly 0 means the cell was never observed (unknown).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np
import numpy.typing as npt

from navd.geometry import Pose2, ScanPoints
from navd.slam import _grid_kernels as k
from navd.slam.likelihood_field import LikelihoodField, gaussian_kernel
from navd.slam.tiles import TiledArray

__all__ = ["OccupancyGrid"]

F32 = npt.NDArray[np.float32]
F64 = npt.NDArray[np.float64]

L_FREE = -0.4  # log-odds added to a cell a ray passes through
L_OCC = 0.85  # log-odds added to the cell a ray ends in
L_MIN, L_MAX = -2.0, 3.5  # clamps: the map stays able to change its mind
OCCUPIED_LOGODDS = 0.0  # above this a cell counts as occupied when matching
# Rows converted at a time by occupancy_percent and coarsened: a band of a map 8000 cells
# wide takes 4 MB in its float64 steps.
PERCENT_ROWS = 64


def _max_every(values: F32, factor: int) -> F32:
    """Row r of the result: the largest of rows r * factor .. r * factor + factor - 1."""
    out = values[0::factor].copy()
    for first in range(1, factor):
        part = values[first::factor]
        np.maximum(out[: part.shape[0]], part, out=out[: part.shape[0]])
    return out


class OccupancyGrid:
    """A log-odds grid that grows in ``chunk_m`` steps to hold what the robot sees.

    The cells are kept in tiles (``TiledArray``) allocated where a ray passed: a large
    building's grid costs the memory of the part the robot saw, not of its bounding box.

    Args:
        resolution: [m] cell size.
        chunk_m: [m] how much the grid grows at a time.
        keep_cells: a ray that hit stops freeing this many cells before its end (see
            ``_grid_kernels.ray_update``; 0: every cell up to the end).
    """

    def __init__(self, resolution: float, chunk_m: float = 10.0, keep_cells: int = 0) -> None:
        self.resolution = resolution
        self.chunk_m = chunk_m
        self.keep_cells = keep_cells
        self.cells_store = TiledArray()
        self.origin_x = 0.0
        self.origin_y = 0.0
        self.revision = 0

    @classmethod
    def from_array(
        cls, logodds: npt.ArrayLike, origin_x: float, origin_y: float, resolution: float
    ) -> OccupancyGrid:
        """A grid holding ``logodds`` (copied, as float32) with that origin and resolution."""
        return cls._of(TiledArray.from_dense(logodds), origin_x, origin_y, resolution)

    @classmethod
    def from_percent(
        cls, occupancy: npt.ArrayLike, origin_x: float, origin_y: float, resolution: float
    ) -> OccupancyGrid:
        """The grid whose ``occupancy_percent`` is ``occupancy`` (-1 unknown, 0..100), as far
        as whole percents allow: a published map (a recording's) to go on from."""
        percent = np.asarray(occupancy, dtype=np.float64)
        p = np.clip(percent / 100.0, 0.005, 0.995)
        logodds = np.log(p / (1.0 - p)).astype(np.float32)
        logodds[(logodds == 0.0) & (percent >= 0)] = 1e-3  # seen, even or odds: not unknown
        logodds[percent < 0] = 0.0
        return cls.from_array(logodds, origin_x, origin_y, resolution)

    @classmethod
    def _of(
        cls, store: TiledArray, origin_x: float, origin_y: float, resolution: float
    ) -> OccupancyGrid:
        grid = cls(resolution)
        grid.cells_store = store
        grid.origin_x, grid.origin_y = origin_x, origin_y
        return grid

    @classmethod
    def from_state(cls, data: Mapping[str, Any], prefix: str = "") -> OccupancyGrid:
        """The grid ``state(prefix)`` wrote, exactly; also a dense ``logodds`` array (maps
        saved before the grid was tiled).

        Raises:
            KeyError: a part is missing; ValueError: parts no save writes (named).
        """
        dense = prefix + "logodds" in data
        parts = ("logodds",) if dense else ("tile_index", "tiles", "tile_offset", "shape")
        for name in ("origin", "resolution", *parts):
            if prefix + name not in data:
                raise KeyError(prefix + name)
        origin = np.asarray(data[prefix + "origin"], dtype=np.float64)
        resolution = np.asarray(data[prefix + "resolution"], dtype=np.float64)
        if origin.shape != (2,) or resolution.shape != ():
            raise ValueError(f"origin {origin.shape} or resolution {resolution.shape} malformed")
        if dense:
            store = TiledArray.from_dense(np.asarray(data[prefix + "logodds"]))
        else:
            store = TiledArray.from_parts(
                data[prefix + "tile_index"],
                data[prefix + "tiles"],
                data[prefix + "tile_offset"],
                data[prefix + "shape"],
            )
        return cls._of(store, float(origin[0]), float(origin[1]), float(resolution))

    def state(self, prefix: str = "") -> dict[str, Any]:
        """The arrays a save writes (each name after ``prefix``): the tiles as they are, so
        the grid reloads bit-exact (``from_state``)."""
        arrays = {
            **self.cells_store.state(),
            "origin": np.array([self.origin_x, self.origin_y]),
            "resolution": np.array(self.resolution),
        }
        return {prefix + name: value for name, value in arrays.items()}

    def copy(self) -> OccupancyGrid:
        """An independent grid with the same cells, frame and revision."""
        grid = self._of(self.cells_store.copy(), self.origin_x, self.origin_y, self.resolution)
        grid.chunk_m, grid.revision = self.chunk_m, self.revision
        grid.keep_cells = self.keep_cells
        return grid

    @property
    def shape(self) -> tuple[int, int]:
        """(rows, cols) of the grid's extent."""
        return (self.cells_store.rows, self.cells_store.cols)

    @property
    def stored_bytes(self) -> int:
        """Bytes the cells take: the tiles allocated, not the extent."""
        return self.cells_store.allocated_bytes

    def to_array(self, rows: slice = slice(None)) -> F32:
        """The log-odds of ``rows`` (a step-1 slice; all by default) over the whole width,
        dense (a copy: of a large map, take a band of rows at a time)."""
        r0, r1, step = rows.indices(self.shape[0])
        if step != 1:
            raise ValueError("to_array takes a slice of rows with step 1")
        return self.cells_store.window(r0, r1, 0, self.shape[1])

    def whole(self) -> tuple[Pose2, float]:
        """The map's middle (yaw 0) and the half-width [m] of the square that holds it."""
        rows, cols = self.shape
        middle = Pose2(
            self.origin_x + 0.5 * cols * self.resolution,
            self.origin_y + 0.5 * rows * self.resolution,
            0.0,
        )
        return middle, 0.5 * max(rows, cols) * self.resolution

    def cropped(self, center: Pose2, radius_m: float) -> OccupancyGrid:
        """The part of the grid within ``radius_m`` of ``center`` (a square; a copy)."""
        res = self.resolution
        col, row = self.cells(np.array([[center.x, center.y]]))[0]
        half = math.ceil(radius_m / res)
        rows, cols = self.shape
        r0, r1 = max(0, int(row) - half), min(rows, int(row) + half + 1)
        c0, c1 = max(0, int(col) - half), min(cols, int(col) + half + 1)
        part = self.cells_store.window(r0, max(r0, r1), c0, max(c0, c1))
        return OccupancyGrid.from_array(
            part, self.origin_x + c0 * res, self.origin_y + r0 * res, res
        )

    def coarsened(self, factor: int) -> OccupancyGrid:
        """The grid with cells ``factor`` times as large, each holding the largest log-odds
        of the cells it covers (occupied if any is): for searches over a whole large map,
        whose fields and bounds at full resolution would not fit a robot's memory. Made a
        band of rows at a time, so it never holds the grid dense."""
        rows, cols = self.shape
        band = factor * max(1, PERCENT_ROWS // factor)
        out = np.zeros((-(-rows // factor), -(-cols // factor)), dtype=np.float32)
        for start in range(0, rows, band):
            rows_max = _max_every(self.cells_store.window(start, start + band, 0, cols), factor)
            blocks = _max_every(rows_max.T, factor).T
            out[start // factor : start // factor + blocks.shape[0]] = blocks
        return OccupancyGrid.from_array(out, self.origin_x, self.origin_y, self.resolution * factor)

    @property
    def empty(self) -> bool:
        """True before the first scan was inserted."""
        return self.shape[0] * self.shape[1] == 0

    def cells(self, points: npt.NDArray[np.float64]) -> npt.NDArray[np.int64]:
        """Integer (col, row) of world points (N x 2) [m]."""
        origin = np.array([self.origin_x, self.origin_y])
        cells: npt.NDArray[np.int64] = np.floor((points - origin) / self.resolution).astype(
            np.int64
        )
        return cells

    def known_fraction(self, pose: Pose2, points: npt.NDArray[np.float64]) -> float:
        """The share of scan points (N x 2, robot frame) that land, from ``pose``, within one
        cell of a cell the map has observed (free or occupied): how much of what the scan sees
        the map already holds. Points in never-seen space tell nothing about the pose."""
        if self.empty or points.shape[0] == 0:
            return 0.0
        cells = self.cells(pose.transform(points))
        known = int(
            k.count_known(*self.cells_store.parts(), cells[:, 0].copy(), cells[:, 1].copy())
        )
        return float(known / points.shape[0])

    def insert(self, pose: Pose2, scan: ScanPoints) -> None:
        """Ray-cast one scan taken at ``pose`` into the grid."""
        hits = pose.transform(scan.hits)
        ends = np.concatenate((hits, pose.transform(scan.misses))) if scan.misses.size else hits
        box = k.extent(ends, float(pose.x), float(pose.y))
        if not math.isfinite(sum(box)):
            raise ValueError(
                f"a scan at {tuple(pose)} holds a point or pose that is not finite (NaN or "
                "infinite): it cannot be drawn into the grid"
            )
        self._cover(*box)
        self.revision += 1
        if ends.shape[0] == 0:
            return  # a blind scan (a covered lidar): the grid holds the pose, nothing more
        res = self.resolution
        # The cells as ``cells`` finds them, and the box of the rays' cells.
        start_col = math.floor((pose.x - self.origin_x) / res)
        start_row = math.floor((pose.y - self.origin_y) / res)
        cols_x, rows_y, c0, c1, r0, r1 = k.cells_and_box(
            ends, self.origin_x, self.origin_y, res, start_col, start_row
        )
        flags = np.zeros(ends.shape[0], dtype=np.bool_)
        flags[: hits.shape[0]] = True
        # Every ray lies in the box around its start and ends: room for all tiles in it.
        self.cells_store.reserve(r0, r1, c0, c1)
        k.ray_update(
            *self.cells_store.parts(),
            start_col,
            start_row,
            cols_x,
            rows_y,
            flags,
            L_FREE,
            L_OCC,
            L_MIN,
            L_MAX,
            self.keep_cells,
        )

    def _cover(self, lo_x: float, lo_y: float, hi_x: float, hi_y: float) -> None:
        """Grow the grid (by whole chunks) until it holds the box from (lo_x, lo_y) to
        (hi_x, hi_y) [m]."""
        res = self.resolution
        if not self.empty:
            rows, cols = self.shape
            if (
                lo_x >= self.origin_x
                and lo_y >= self.origin_y
                and hi_x < self.origin_x + cols * res
                and hi_y < self.origin_y + rows * res
            ):
                return  # (most scans)
        lo, hi = np.array([lo_x, lo_y]), np.array([hi_x, hi_y])
        if self.empty:
            new_lo = np.floor((lo - self.chunk_m / 2) / res) * res
            new_hi = np.ceil((hi + self.chunk_m / 2) / res) * res
        else:
            old_lo = np.array([self.origin_x, self.origin_y])
            old_hi = old_lo + np.array([cols, rows]) * res
            grow_lo = np.where(lo < old_lo, self.chunk_m, 0.0)
            grow_hi = np.where(hi >= old_hi, self.chunk_m, 0.0)
            new_lo = old_lo - np.ceil(np.maximum(old_lo - lo, 0) / self.chunk_m) * grow_lo
            new_hi = old_hi + np.ceil(np.maximum(hi - old_hi + res, 0) / self.chunk_m) * grow_hi
        cols = round((new_hi[0] - new_lo[0]) / res)
        rows = round((new_hi[1] - new_lo[1]) / res)
        if self.empty:
            self.cells_store = TiledArray(rows, cols)
        else:
            off_c = round((self.origin_x - new_lo[0]) / res)
            off_r = round((self.origin_y - new_lo[1]) / res)
            self.cells_store.grow(rows, cols, off_r, off_c)
        self.origin_x, self.origin_y = float(new_lo[0]), float(new_lo[1])

    def likelihood_field(
        self, center: Pose2, radius_m: float, sigma_m: float, out: F32 | None = None
    ) -> LikelihoodField:
        """The blurred occupied cells within ``radius_m`` of ``center`` (a square window).

        Args:
            out: an array to draw it in if it has the window's shape (float32, C order;
                otherwise a new one is made); a field drawn again and again (the fine map's)
                then allocates nothing. A field whose array it was is no longer good.
        """
        res = self.resolution
        half = math.ceil(radius_m / res)
        col, row = self.cells(np.array([[center.x, center.y]]))[0]
        col0, row0 = int(col) - half, int(row) - half
        shape = (2 * half + 1, 2 * half + 1)
        if out is not None and out.shape == shape and out.flags.c_contiguous:
            values = out
            values.fill(0.0)
        else:
            values = np.zeros(shape, dtype=np.float32)
        k.smear(
            *self.cells_store.parts(),
            OCCUPIED_LOGODDS,
            row0,
            col0,
            gaussian_kernel(sigma_m, res),
            values,
        )
        return LikelihoodField(values, self.origin_x + col0 * res, self.origin_y + row0 * res, res)

    def stamp_points(self, field: LikelihoodField, points: F64, sigma_m: float) -> LikelihoodField:
        """``field`` (drawn from this grid by ``likelihood_field`` with ``sigma_m``) with the
        cells under ``points`` (map frame, N x 2 [m]) that are occupied now stamped in, as
        ``likelihood_field`` stamps every occupied cell: after a scan is inserted, its hits
        are the only cells that can have become occupied, so stamping them brings the field up
        to date but for the cells the scan freed (still stamped, until the field is drawn
        anew). Drawn into ``field``'s array; returned as a new field (no bounds cached)."""
        res = self.resolution
        col0 = round((field.origin_x - self.origin_x) / res)
        row0 = round((field.origin_y - self.origin_y) / res)
        k.smear_cells(
            *self.cells_store.parts(),
            OCCUPIED_LOGODDS,
            self.cells(points),
            row0,
            col0,
            gaussian_kernel(sigma_m, res),
            field.values,
        )
        return LikelihoodField(field.values, field.origin_x, field.origin_y, res)

    def occupancy_percent(self, rows: slice = slice(None)) -> npt.NDArray[np.int8]:
        """ROS OccupancyGrid values of ``rows`` (a step-1 slice; all by default): -1 unknown,
        else 0..100 probability of occupied.

        Converted a band of rows at a time: the float64 steps of a whole large map (fr-clinic,
        41 million cells) took over 1 GB at once for a 41 MB answer. Of a large map, take a
        band of rows at a time too.
        """
        r0, r1, step = rows.indices(self.shape[0])
        if step != 1:
            raise ValueError("occupancy_percent takes a slice of rows with step 1")
        out = np.empty((max(r1 - r0, 0), self.shape[1]), dtype=np.int8)
        for start in range(r0, r1, PERCENT_ROWS):
            band = self.to_array(slice(start, min(start + PERCENT_ROWS, r1)))
            p = 1.0 - 1.0 / (1.0 + np.exp(band.astype(np.float64)))
            values = np.round(p * 100.0).astype(np.int8)
            values[band == 0.0] = -1
            out[start - r0 : start - r0 + band.shape[0]] = values
        return out
