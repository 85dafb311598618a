"""The costmap: static, obstacle and keep-out layers, inflated by a Euclidean distance transform.

Cells are indexed (row, column) = (y, x) like the occupancy grid, cell (0, 0)'s corner at the
frame's origin. Three layers make the obstacle cells: the SLAM map's occupied cells (static),
cells where live scans saw something within ``obstacle_persistence_s`` (obstacle; cleared by
rays passing through), and keep-out polygons from config. Their distance transform gives every
cell its clearance [m]; a cell whose clearance is below the footprint's inscribed radius plus
the collision margin cannot hold the robot's centre, and cost decays exponentially from there
out to the inflation radius (Nav2's inflation layer idea).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from navd.planning._costmap_kernels import mark_and_clear
from navd.planning._distance_kernels import distance_to

__all__ = [
    "Costmap",
    "CostmapSettings",
    "GridFrame",
    "ObstacleLayer",
    "build_costmap",
    "keep_out_mask",
    "ros_costmap",
    "static_layer",
]

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]
IntArray = npt.NDArray[np.int64]


@dataclass(frozen=True, slots=True)
class GridFrame:
    """Where a grid lies in the map frame.

    Attributes:
        resolution_m: [m] cell size.
        origin_x_m, origin_y_m: [m] map position of cell (0, 0)'s lower-left corner.
        rows, cols: grid shape (y cells, x cells).
    """

    resolution_m: float
    origin_x_m: float
    origin_y_m: float
    rows: int
    cols: int

    @property
    def shape(self) -> tuple[int, int]:
        """(rows, cols)."""
        return (self.rows, self.cols)

    def cell_of(self, x_m: float, y_m: float) -> tuple[int, int]:
        """The (row, column) holding map point (x_m, y_m); may lie outside the grid."""
        return (
            math.floor((y_m - self.origin_y_m) / self.resolution_m),
            math.floor((x_m - self.origin_x_m) / self.resolution_m),
        )

    def cells_of(self, points_m: FloatArray) -> IntArray:
        """N x 2 (row, column) of N x 2 map points."""
        cols = np.floor((points_m[:, 0] - self.origin_x_m) / self.resolution_m)
        rows = np.floor((points_m[:, 1] - self.origin_y_m) / self.resolution_m)
        return np.column_stack([rows, cols]).astype(np.int64)

    def centers_of(self, cells: IntArray) -> FloatArray:
        """[m] N x 2 map (x, y) of the centres of N x 2 (row, column) cells."""
        x = self.origin_x_m + (cells[:, 1] + 0.5) * self.resolution_m
        y = self.origin_y_m + (cells[:, 0] + 0.5) * self.resolution_m
        return np.column_stack([x, y])

    def contains(self, row: int, col: int) -> bool:
        """True if (row, col) is a cell of the grid."""
        return 0 <= row < self.rows and 0 <= col < self.cols


def static_layer(
    occupancy: npt.NDArray[np.int8], threshold_pct: int
) -> tuple[BoolArray, BoolArray]:
    """Obstacle and unknown cells of an occupancy grid (-1 unknown, 0..100 percent).

    Returns:
        (occupied, unknown) masks: occupied at or above ``threshold_pct``, unknown where -1.
    """
    occupied = occupancy >= threshold_pct
    unknown = occupancy < 0
    return occupied, unknown


class ObstacleLayer:
    """Obstacles seen by live scans: marked where rays end, cleared where rays pass.

    Args:
        frame: the grid, normally the static map's.
        persistence_s: [s] a mark not seen again for this long is forgotten.
    """

    def __init__(self, frame: GridFrame, persistence_s: float) -> None:
        self.frame = frame
        self.persistence_s = persistence_s
        self.last_seen: FloatArray = np.full(frame.shape, -np.inf)

    def add_scan(
        self,
        sensor_xy_m: tuple[float, float],
        hits_m: FloatArray,
        misses_m: FloatArray,
        stamp: float,
    ) -> None:
        """Clear along every ray of a scan and mark its hits.

        Args:
            sensor_xy_m: [m] the lidar's map position.
            hits_m: [m] N x 2 map points where rays hit something.
            misses_m: [m] M x 2 map points where rays ended without a return.
            stamp: [s] the scan's time.
        """
        origin = self.frame.cell_of(*sensor_xy_m)
        ends = np.concatenate([hits_m.reshape(-1, 2), misses_m.reshape(-1, 2)])
        is_hit = np.zeros(ends.shape[0], dtype=np.bool_)
        is_hit[: hits_m.shape[0]] = True
        mark_and_clear(
            self.last_seen, origin[0], origin[1], self.frame.cells_of(ends), is_hit, stamp
        )

    def active(self, now: float) -> BoolArray:
        """Cells seen occupied within the persistence time before ``now``."""
        mask: BoolArray = self.last_seen >= now - self.persistence_s
        return mask

    def active_bounds(self, now: float) -> tuple[float, float, float, float] | None:
        """[m] (min x, min y, max x, max y) of the cells active at ``now``, None if none."""
        mask = self.active(now)
        rows = np.flatnonzero(mask.any(axis=1))
        if rows.size == 0:
            return None
        cols = np.flatnonzero(mask[rows[0] : rows[-1] + 1].any(axis=0))
        f = self.frame
        return (
            f.origin_x_m + cols[0] * f.resolution_m,
            f.origin_y_m + rows[0] * f.resolution_m,
            f.origin_x_m + (cols[-1] + 1) * f.resolution_m,
            f.origin_y_m + (rows[-1] + 1) * f.resolution_m,
        )

    def clear_disc(self, x_m: float, y_m: float, radius_m: float) -> None:
        """Forget every mark within ``radius_m`` of (x_m, y_m) (stuck recovery)."""
        rows, cols = np.ogrid[: self.frame.rows, : self.frame.cols]
        cx, cy = x_m - self.frame.origin_x_m, y_m - self.frame.origin_y_m
        res = self.frame.resolution_m
        inside = ((cols + 0.5) * res - cx) ** 2 + ((rows + 0.5) * res - cy) ** 2 <= radius_m**2
        self.last_seen[inside] = -np.inf

    def reframe(self, frame: GridFrame) -> None:
        """Move to a new grid (the map grew), keeping the marks both grids cover.

        Raises:
            ValueError: the resolutions differ or the origins are not a whole number of cells
                apart.
        """
        if frame == self.frame:
            return
        res = self.frame.resolution_m
        shift_c = (self.frame.origin_x_m - frame.origin_x_m) / res
        shift_r = (self.frame.origin_y_m - frame.origin_y_m) / res
        if (
            frame.resolution_m != res
            or abs(shift_c - round(shift_c)) > 1e-6
            or abs(shift_r - round(shift_r)) > 1e-6
        ):
            raise ValueError(
                f"cannot move obstacle marks from {self.frame} to {frame}: the grids' cells "
                "do not line up"
            )
        dr, dc = round(shift_r), round(shift_c)
        new = np.full(frame.shape, -np.inf)
        r0, c0 = max(dr, 0), max(dc, 0)
        r1 = min(frame.rows, dr + self.frame.rows)
        c1 = min(frame.cols, dc + self.frame.cols)
        if r1 > r0 and c1 > c0:
            new[r0:r1, c0:c1] = self.last_seen[r0 - dr : r1 - dr, c0 - dc : c1 - dc]
        self.frame = frame
        self.last_seen = new


def keep_out_mask(frame: GridFrame, polygons: Sequence[Sequence[tuple[float, float]]]) -> BoolArray:
    """Cells whose centre lies inside any polygon (even-odd rule), vertices in map metres."""
    mask = np.zeros(frame.shape, dtype=np.bool_)
    if not polygons:
        return mask
    res = frame.resolution_m
    xs = frame.origin_x_m + (np.arange(frame.cols) + 0.5) * res
    ys = frame.origin_y_m + (np.arange(frame.rows) + 0.5) * res
    px, py = np.meshgrid(xs, ys)
    for polygon in polygons:
        vertices = np.asarray(polygon, dtype=np.float64)
        inside = np.zeros(frame.shape, dtype=np.bool_)
        for (x0, y0), (x1, y1) in zip(vertices, np.roll(vertices, -1, axis=0), strict=True):
            # A horizontal ray to +x from each cell centre crosses this edge?
            straddles = (y0 > py) != (y1 > py)
            with np.errstate(divide="ignore", invalid="ignore"):
                x_cross = x0 + (py - y0) * (x1 - x0) / (y1 - y0)
            inside ^= straddles & (px < x_cross)
        mask |= inside
    return mask


@dataclass(frozen=True, slots=True)
class CostmapSettings:
    """What the inflation needs, in plain values.

    Attributes:
        robot_radius_m: [m] the footprint's inscribed radius plus the collision margin: a cell
            closer than this to an obstacle cannot hold the robot's centre.
        inflation_radius_m: [m] cost reaches zero this far from obstacles.
        cost_decay_per_m: [1/m] exponential decay of the cost beyond robot_radius_m.
        allow_unknown: unknown cells are traversable (at ``unknown_cost``).
        unknown_cost: [0..1] the cost of an unknown cell.
        occupied_threshold_pct: [%] map cells at or above are obstacles.
    """

    robot_radius_m: float
    inflation_radius_m: float
    cost_decay_per_m: float
    allow_unknown: bool
    unknown_cost: float
    occupied_threshold_pct: int


@dataclass(frozen=True, slots=True)
class Costmap:
    """An inflated costmap, ready for A* and for clearance look-ups.

    Attributes:
        frame: where the grid lies.
        obstacles: cells holding an obstacle (any layer).
        clearance_m: [m] distance from each cell centre to the nearest obstacle cell centre
            (inf when there is none).
        cost: [0..1] cost of each cell for the robot's centre; inf where it cannot be.
        blocked: the cells of infinite cost, one byte a cell: jump point search packs them
            into bits at every search, and reading a quarter of the bytes the costs take is
            about half its packing time.
        unknown: cells never observed.
        unknown_blocks: unknown cells cannot be crossed (``planning.allow_unknown`` false);
            otherwise an unknown cell of infinite cost is blocked by a nearby obstacle.
    """

    frame: GridFrame
    obstacles: BoolArray
    clearance_m: npt.NDArray[np.float32]
    cost: npt.NDArray[np.float32]
    blocked: BoolArray
    unknown: BoolArray
    unknown_blocks: bool


def build_costmap(
    frame: GridFrame, obstacles: BoolArray, unknown: BoolArray, settings: CostmapSettings
) -> Costmap:
    """Inflate obstacle cells into a costmap.

    Args:
        frame: the grid.
        obstacles: cells holding an obstacle (the union of the layers).
        unknown: cells never observed.
        settings: robot radius, inflation and unknown handling.
    """
    if obstacles.shape != frame.shape or unknown.shape != frame.shape:
        raise ValueError(
            f"layer shapes {obstacles.shape} and {unknown.shape} differ from the frame's "
            f"{frame.shape}"
        )
    if obstacles.any():
        clearance = distance_to(obstacles).astype(np.float32)
        clearance *= np.float32(frame.resolution_m)
    else:
        clearance = np.full(frame.shape, np.inf, dtype=np.float32)
    cost = np.zeros(frame.shape, dtype=np.float32)
    soft = clearance < settings.inflation_radius_m
    cost[soft] = np.exp(
        -settings.cost_decay_per_m * (clearance[soft] - settings.robot_radius_m)
    ).clip(0.0, 1.0)
    blocked = clearance < settings.robot_radius_m
    if settings.allow_unknown:
        cost[unknown] = np.maximum(cost[unknown], settings.unknown_cost)
    else:
        blocked |= unknown
    cost[blocked] = np.inf
    return Costmap(
        frame,
        obstacles=obstacles.copy(),
        clearance_m=clearance,
        cost=cost,
        blocked=blocked,
        unknown=unknown.copy(),
        unknown_blocks=not settings.allow_unknown,
    )


def ros_costmap(costmap: Costmap) -> npt.NDArray[np.int8]:
    """The costmap as ROS shows one (int8): -1 unknown, 0..98 by cost, 99 where the robot's
    centre cannot be, 100 an obstacle."""
    cells: npt.NDArray[np.int8] = np.rint(np.nan_to_num(costmap.cost, posinf=1.0) * 98.0).astype(
        np.int8
    )
    cells[costmap.blocked] = 99
    cells[costmap.unknown] = -1
    cells[costmap.obstacles] = 100
    return cells
