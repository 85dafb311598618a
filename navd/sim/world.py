"""Simulated worlds: a fine occupancy grid of static shapes, plus discs moving on paths.

A world comes from a TOML list of shapes, from a map_server PGM + YAML, or is the built-in
office. TOML shapes (all in metres, map frame):

```toml
resolution_m = 0.02
walls = [[x0, y0, x1, y1], ...]          # segments, 5 cm thick
boxes = [[x, y, width, height], ...]      # axis-aligned, (x, y) is the lower-left corner
circles = [[x, y, radius], ...]
movers = [{radius = 0.25, speed = 0.5, path = [[x, y], [x, y], ...]}]   # back and forth
beacons = [{id = "B1", x = 0.0, y = 5.0}]  # points a beacon sensor ranges and bears to
start = [x, y, yaw]                       # where the robot starts (default 0 0 0)
goal = [x, y, yaw]                        # the demo's goal (optional)
glass = [[x0, y0, x1, y1], ...]           # panes: the lidar sees through, a sonar hears
low_boxes = [[x, y, width, height], ...]  # LOW_HEIGHT_M tall: under the lidar's plane
tables = [[x, y, width, height], ...]     # a top TABLE_UNDERSIDE_M to TABLE_TOP_M up, on
                                          # four legs the lidar sees
drops = [[x, y, width, height], ...]      # where the floor falls away (stairs down)
```

Walls, boxes, circles and movers are full height: every sensor sees them. What else a
sensor perceives: a lidar (at ``LIDAR_HEIGHT_M``) none of the rest; a range sensor the
glass; a depth camera the low boxes and the table tops (not the glass); a bumper and the
body all of them but the drops; a cliff sensor only the drops, where the body falls.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import tomllib
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import numpy.typing as npt

from navd.geometry import IDENTITY, Pose2
from navd.sim.errors import WorldError

__all__ = [
    "LOW_HEIGHT_M",
    "TABLE_TOP_M",
    "TABLE_UNDERSIDE_M",
    "Mover",
    "World",
    "load_world",
    "office",
]

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]
WALL_THICKNESS_M = 0.05
LOW_HEIGHT_M = 0.1  # [m] a low box's height
TABLE_UNDERSIDE_M, TABLE_TOP_M = 0.6, 0.75  # [m] a table top's heights
TABLE_LEG_RADIUS_M = 0.03


@dataclass(frozen=True, slots=True)
class Mover:
    """A disc going back and forth along a polyline at a constant speed.

    Attributes:
        radius_m: [m] disc radius.
        speed_mps: [m/s] speed along the path.
        path_m: [m] N x 2 waypoints.
    """

    radius_m: float
    speed_mps: float
    path_m: FloatArray

    def position(self, t_s: float) -> tuple[float, float]:
        """[m] the disc's centre at time ``t_s`` [s] (t = 0 at the first waypoint)."""
        steps = np.hypot(*np.diff(self.path_m, axis=0).T)
        length = float(steps.sum())
        if length == 0.0:
            return float(self.path_m[0, 0]), float(self.path_m[0, 1])
        s = (self.speed_mps * t_s) % (2.0 * length)
        s = 2.0 * length - s if s > length else s  # back on the way home
        along = np.concatenate([[0.0], np.cumsum(steps)])
        return (
            float(np.interp(s, along, self.path_m[:, 0])),
            float(np.interp(s, along, self.path_m[:, 1])),
        )


@dataclass(frozen=True)
class World:  # (not slotted: ``solid`` is computed once and kept)
    """Static obstacles as a grid, moving discs, and the scenario's start and goal.

    Attributes:
        grid: rows x cols, True where occupied (row = y).
        origin_x_m, origin_y_m: [m] corner of cell (0, 0).
        resolution_m: [m] cell size.
        movers: the moving discs.
        start: the robot's start pose.
        goal: the scenario's goal pose, if it has one.
        beacons: (id, x [m], y [m]) of each beacon (no body: only a beacon sensor sees it).
        glass, low, tables, drops: cells of the shapes the lidar does not see (None: none;
            see the module docstring).
    """

    grid: npt.NDArray[np.bool_]
    origin_x_m: float
    origin_y_m: float
    resolution_m: float
    movers: tuple[Mover, ...] = ()
    start: Pose2 = IDENTITY
    goal: Pose2 | None = None
    name: str = field(default="world")
    beacons: tuple[tuple[str, float, float], ...] = ()
    glass: BoolArray | None = None
    low: BoolArray | None = None
    tables: BoolArray | None = None
    drops: BoolArray | None = None

    @functools.cached_property
    def solid(self) -> BoolArray:
        """Every cell the body cannot enter: what the lidar sees and what it does not."""
        solid = self.grid.copy()
        for hidden in (self.glass, self.low, self.tables):
            if hidden is not None:
                solid |= hidden
        return solid

    def discs(self, t_s: float) -> FloatArray:
        """K x 3 (x, y, radius) [m] of the movers at time ``t_s`` [s]."""
        if not self.movers:
            return np.empty((0, 3))
        return np.array([(*m.position(t_s), m.radius_m) for m in self.movers])

    @property
    def extent(self) -> tuple[float, float, float, float]:
        """[m] (x_min, y_min, x_max, y_max)."""
        rows, cols = self.grid.shape
        return (
            self.origin_x_m,
            self.origin_y_m,
            self.origin_x_m + cols * self.resolution_m,
            self.origin_y_m + rows * self.resolution_m,
        )


def _pairs(value: object, width: int, key: str) -> list[tuple[float, ...]]:
    """A list of number rows of ``width``, or a WorldError naming ``key``."""
    if not isinstance(value, list):
        raise WorldError(f"{key} must be a list of [{width} numbers] rows, got {value!r}")
    rows = []
    for i, row in enumerate(value):
        if (
            not isinstance(row, list)
            or len(row) != width
            or not all(isinstance(v, int | float) and math.isfinite(v) for v in row)
        ):
            raise WorldError(f"{key}[{i}] must be {width} finite numbers, got {row!r}")
        rows.append(tuple(float(v) for v in row))
    return rows


def from_shapes(spec: dict[str, object], name: str = "world") -> World:
    """A world from a parsed TOML table of shapes (see the module docstring).

    Raises:
        WorldError: an unknown key, a malformed shape or a world with nothing in it.
    """
    known = {
        "resolution_m", "walls", "boxes", "circles", "movers", "start", "goal", "margin_m",
        "beacons", "glass", "low_boxes", "tables", "drops",
    }  # fmt: skip
    unknown = set(spec) - known
    if unknown:
        raise WorldError(f"unknown world keys {sorted(unknown)}; known: {sorted(known)}")
    res = spec.get("resolution_m", 0.02)
    if not isinstance(res, int | float) or not 0.005 <= res <= 0.2:
        raise WorldError(f"resolution_m must be a number in [0.005, 0.2] m, got {res!r}")
    shapes: dict[str, list[tuple[float, ...]]] = {"none": []} | {
        key: _pairs(spec.get(key, []), width, key)
        for key, width in (
            ("walls", 4), ("boxes", 4), ("circles", 3), ("glass", 4), ("low_boxes", 4),
            ("tables", 4), ("drops", 4),
        )
    }  # fmt: skip
    if not (shapes["walls"] or shapes["boxes"] or shapes["circles"]):
        raise WorldError("a world needs at least one of walls, boxes or circles")
    legs = [
        (x + dx, y + dy, TABLE_LEG_RADIUS_M)
        for x, y, w, h in shapes["tables"]
        for dx in (TABLE_LEG_RADIUS_M, w - TABLE_LEG_RADIUS_M)
        for dy in (TABLE_LEG_RADIUS_M, h - TABLE_LEG_RADIUS_M)
    ]
    canvas = _Canvas(float(res), shapes)
    grid = canvas.draw(shapes["walls"], shapes["boxes"], [*shapes["circles"], *legs])

    def hidden(walls: str, boxes: str) -> BoolArray | None:
        if not (shapes[walls] or shapes[boxes]):
            return None
        return canvas.draw(shapes[walls], shapes[boxes], [])

    ox, oy = canvas.origin
    movers = []
    raw_movers = spec.get("movers", [])
    if not isinstance(raw_movers, list):
        raise WorldError("movers must be a list of tables {radius, speed, path}")
    for i, m in enumerate(raw_movers):
        if not isinstance(m, dict) or set(m) != {"radius", "speed", "path"}:
            raise WorldError(f"movers[{i}] must be a table with radius, speed and path")
        path = np.array(_pairs(m["path"], 2, f"movers[{i}].path"))
        if len(path) < 1 or not m["radius"] > 0 or not m["speed"] >= 0:
            raise WorldError(f"movers[{i}] needs a path, a radius > 0 and a speed >= 0")
        movers.append(Mover(float(m["radius"]), float(m["speed"]), path))
    start = _pose(spec.get("start", [0.0, 0.0, 0.0]), "start")
    goal = _pose(spec["goal"], "goal") if "goal" in spec else None
    beacons = _beacons(spec.get("beacons", []))
    return World(
        grid,
        ox,
        oy,
        float(res),
        tuple(movers),
        start,
        goal,
        name,
        beacons,
        glass=hidden("glass", "none"),
        low=hidden("none", "low_boxes"),
        tables=hidden("none", "tables"),
        drops=hidden("none", "drops"),
    )


class _Canvas:
    """Shapes drawn on grids of one frame, which holds all of ``shapes`` with a margin."""

    def __init__(self, res: float, shapes: dict[str, list[tuple[float, ...]]]) -> None:
        xs: list[float] = []
        ys: list[float] = []
        for key in ("walls", "glass"):
            xs += [v for w in shapes[key] for v in (w[0], w[2])]
            ys += [v for w in shapes[key] for v in (w[1], w[3])]
        for key in ("boxes", "low_boxes", "tables", "drops"):
            xs += [v for b in shapes[key] for v in (b[0], b[0] + b[2])]
            ys += [v for b in shapes[key] for v in (b[1], b[1] + b[3])]
        xs += [v for c in shapes["circles"] for v in (c[0] - c[2], c[0] + c[2])]
        ys += [v for c in shapes["circles"] for v in (c[1] - c[2], c[1] + c[2])]
        margin = 1.0
        self.res = res
        self.origin = (min(xs) - margin, min(ys) - margin)
        ox, oy = self.origin
        self.cols = math.ceil((max(xs) + margin - ox) / res)
        self.rows = math.ceil((max(ys) + margin - oy) / res)
        self.cx = ox + (np.arange(self.cols) + 0.5) * res
        self.cy = oy + (np.arange(self.rows) + 0.5) * res

    def draw(
        self,
        walls: list[tuple[float, ...]],
        boxes: list[tuple[float, ...]],
        circles: list[tuple[float, ...]],
    ) -> BoolArray:
        """A grid of these shapes.

        Raises:
            WorldError: a box or circle without a size.
        """
        res, (ox, oy), cx, cy = self.res, self.origin, self.cx, self.cy
        rows, cols = self.rows, self.cols
        grid = np.zeros((rows, cols), dtype=np.bool_)
        for x0, y0, x1, y1 in walls:
            # Cells whose centre is within half the thickness of the segment.
            lo_c, hi_c = _span(min(x0, x1), max(x0, x1), ox, res, cols)
            lo_r, hi_r = _span(min(y0, y1), max(y0, y1), oy, res, rows)
            px, py = np.meshgrid(cx[lo_c:hi_c], cy[lo_r:hi_r])
            ex, ey = x1 - x0, y1 - y0
            length2 = max(ex * ex + ey * ey, 1e-12)
            t = np.clip(((px - x0) * ex + (py - y0) * ey) / length2, 0.0, 1.0)
            near = np.hypot(px - x0 - t * ex, py - y0 - t * ey) <= WALL_THICKNESS_M / 2
            grid[lo_r:hi_r, lo_c:hi_c] |= near
        for x, y, w, h in boxes:
            if w <= 0 or h <= 0:
                raise WorldError(f"box at ({x}, {y}) needs a positive width and height")
            lo_c, hi_c = _span(x, x + w, ox, res, cols)
            lo_r, hi_r = _span(y, y + h, oy, res, rows)
            inside_c = (cx[lo_c:hi_c] >= x) & (cx[lo_c:hi_c] <= x + w)
            inside_r = (cy[lo_r:hi_r] >= y) & (cy[lo_r:hi_r] <= y + h)
            grid[lo_r:hi_r, lo_c:hi_c] |= inside_r[:, None] & inside_c[None, :]
        for x, y, radius in circles:
            if radius <= 0:
                raise WorldError(f"circle at ({x}, {y}) needs a positive radius")
            lo_c, hi_c = _span(x - radius, x + radius, ox, res, cols)
            lo_r, hi_r = _span(y - radius, y + radius, oy, res, rows)
            dx2 = (cx[None, lo_c:hi_c] - x) ** 2
            grid[lo_r:hi_r, lo_c:hi_c] |= dx2 + (cy[lo_r:hi_r, None] - y) ** 2 <= radius**2
        return grid


def _beacons(value: object) -> tuple[tuple[str, float, float], ...]:
    """The beacons table list as (id, x, y), or a WorldError naming the bad one."""
    if not isinstance(value, list):
        raise WorldError("beacons must be a list of tables {id, x, y}")
    beacons = []
    for i, b in enumerate(value):
        if not isinstance(b, dict) or set(b) != {"id", "x", "y"} or not isinstance(b["id"], str):
            raise WorldError(f"beacons[{i}] must be a table with id (a string), x and y")
        x, y = _pairs([[b["x"], b["y"]]], 2, f"beacons[{i}]")[0]
        beacons.append((b["id"], x, y))
    ids = [b[0] for b in beacons]
    if len(set(ids)) != len(ids):
        raise WorldError(f"beacon ids must differ, got {ids}")
    return tuple(beacons)


def _span(lo: float, hi: float, origin: float, res: float, n: int) -> tuple[int, int]:
    pad = WALL_THICKNESS_M
    return (
        max(math.floor((lo - pad - origin) / res), 0),
        min(math.ceil((hi + pad - origin) / res) + 1, n),
    )


def _pose(value: object, key: str) -> Pose2:
    row = _pairs([value], 3, key)[0]
    return Pose2(row[0], row[1], row[2])


def load_world(path: Path) -> World:
    """A world from a TOML file of shapes, or a map_server ``.yaml`` (occupied cells).

    Raises:
        WorldError: the file is missing, unreadable or malformed.
    """
    if not path.is_file():
        raise WorldError(f"world file {path} does not exist")
    if path.suffix in (".yaml", ".yml"):
        from navd.slam import (  # noqa: PLC0415
            MapFileError,
            load_map,
        )

        try:
            grid = load_map(path)
        except MapFileError as err:
            raise WorldError(f"world map {path}: {err}") from err
        occupied = grid.occupancy_percent() >= 65
        return World(occupied, grid.origin_x, grid.origin_y, grid.resolution, name=path.stem)
    try:
        spec = tomllib.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError) as err:
        raise WorldError(f"world file {path}: {err}") from err
    return from_shapes(spec, path.stem)


def office(movers: Sequence[Mover] = ()) -> World:
    """The built-in office: a 12 m x 8 m floor with two rooms, a corridor, doors, desks and a
    pillar; the robot starts in the lower-left room and the goal is in the upper-right one."""
    walls = [
        [-1.0, -1.0, 11.0, -1.0],
        [11.0, -1.0, 11.0, 7.0],
        [11.0, 7.0, -1.0, 7.0],
        [-1.0, 7.0, -1.0, -1.0],
        # The lower-left room's walls, a door at x 3.0..4.0 to the corridor.
        [-1.0, 2.5, 3.0, 2.5],
        [4.0, 2.5, 5.0, 2.5],
        [5.0, 2.5, 5.0, -1.0],
        # The upper-right room, a door at x 6.0..7.0.
        [5.0, 4.0, 6.0, 4.0],
        [7.0, 4.0, 11.0, 4.0],
        [5.0, 4.0, 5.0, 7.0],
    ]
    spec: dict[str, object] = {
        "walls": walls,
        "boxes": [[1.5, 0.8, 1.2, 0.6], [8.0, 5.6, 1.5, 0.8], [7.0, 0.5, 0.8, 1.5]],
        "circles": [[2.0, 4.5, 0.25]],
        "start": [0.0, 0.0, 0.0],
        "goal": [9.5, 5.0, 1.5708],
    }
    world = from_shapes(spec, "office")
    if movers:
        world = dataclasses.replace(world, movers=tuple(movers))
    return world
