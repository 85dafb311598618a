"""What the planner knows about the world: the SLAM map, scan obstacles and keep-out zones.

Scan obstacles are in two layers alike in all but who clears them: what lidars mark and
clear, and what the proximity sensors mark (range sensors, depth cameras, bumpers and cliff
sensors), which lidar rays never clear: a lidar looks through the glass an ultrasonic
sensor hears, and under the table top a depth camera sees.

The layers live on the map's cell lattice. A snapshot for A* covers the map grown (in whole
cells) to hold the robot and the goal with ``FRAME_MARGIN_M`` to spare; unmapped cells are
unknown. For a far goal (``horizon``) there are two snapshots instead: a window of the
lattice around the robot, and the whole area on a coarse lattice of whole blocks of cells (a
block is an obstacle if any of its cells is, unknown if all are). The obstacle layer follows
the fine snapshot's frame, keeping its marks where the frames overlap (a far goal's window
keeps only those around the robot); if the lattice itself changes (a new map with
another origin or resolution) it starts afresh, its marks last only
``obstacle_persistence_s`` anyway.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from navd.geometry import ALL_AROUND, FieldOfView, Pose2
from navd.planning.costmap import GridFrame, ObstacleLayer, keep_out_mask, static_layer
from navd.planning.errors import GoalRefusedError
from navd.planning.lattice import (
    aligned,
    cells_near,
    cells_of,
    overlap,
    pooled,
    snap,
    window_around,
)
from navd.planning.live_points import LivePoints
from navd.planning.zones import ZoneMasks

__all__ = ["FRAME_MARGIN_M", "LayerSettings", "Layers"]

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]
Zones = tuple[tuple[tuple[float, float], ...], ...]

# Unmapped space planned through around the robot and the goal [m].
FRAME_MARGIN_M = 3.0
# Cell size [m] before a map arrives.
DEFAULT_RESOLUTION_M = 0.05


@dataclass(frozen=True, slots=True)
class LayerSettings:
    """What the layers are made of.

    Attributes:
        occupied_threshold_pct: [%] map cells at or above this occupancy are obstacles.
        obstacle_persistence_s: [s] a scan obstacle not seen again is forgotten after this.
        keep_out_zones: [m] polygons in the map frame the robot must never enter.
        max_cells: [cells] the largest snapshot A* may be given (its memory and time).
        keep_out_mask, speed_mask: the zone masks' YAML files, or None.
        window_m: [m] side of the fine window around the robot for a far goal.
        proximity_persistence_s: [s] what a proximity sensor saw is forgotten after this.
    """

    occupied_threshold_pct: int
    obstacle_persistence_s: float
    keep_out_zones: Zones
    max_cells: int
    keep_out_mask: str | None = None
    speed_mask: str | None = None
    window_m: float = 30.0
    proximity_persistence_s: float = 20.0


class Layers:
    """The static, obstacle and keep-out layers.

    Args:
        settings: occupancy threshold, obstacle persistence and keep-out zones.
    """

    def __init__(self, settings: LayerSettings) -> None:
        self.settings = settings
        self.map: tuple[GridFrame, BoolArray, BoolArray] | None = None
        self._occupancy: npt.NDArray[np.int8] | None = None
        self.obstacles: ObstacleLayer | None = None
        self.proximity: ObstacleLayer | None = None  # marks lidar rays never clear
        self.live = LivePoints()  # every source's latest hits, the fleet's robots
        self._keep_out: tuple[GridFrame, Zones, int, BoolArray] | None = None
        self.zones = ZoneMasks(settings.keep_out_mask, settings.speed_mask)

    def configure(self, settings: LayerSettings) -> None:
        """Take new settings; the map and the scan obstacles seen so far stay."""
        old, self.settings = self.settings, settings
        if (settings.keep_out_mask, settings.speed_mask) != self.zones.paths:
            self.zones = ZoneMasks(settings.keep_out_mask, settings.speed_mask)
        if self.obstacles is not None:
            self.obstacles.persistence_s = settings.obstacle_persistence_s
        if self.proximity is not None:
            self.proximity.persistence_s = settings.proximity_persistence_s
        threshold_moved = settings.occupied_threshold_pct != old.occupied_threshold_pct
        if threshold_moved and self.map is not None and self._occupancy is not None:
            self._place_map(self.map[0], self._occupancy)

    def set_map(
        self,
        occupancy: npt.NDArray[np.int8],
        resolution_m: float,
        origin_x_m: float,
        origin_y_m: float,
    ) -> None:
        """Take the SLAM map (-1 unknown, 0..100 % occupied; row = y)."""
        rows, cols = occupancy.shape
        self._place_map(GridFrame(resolution_m, origin_x_m, origin_y_m, rows, cols), occupancy)

    def _place_map(self, frame: GridFrame, occupancy: npt.NDArray[np.int8]) -> None:
        occupied, unknown = static_layer(occupancy, self.settings.occupied_threshold_pct)
        self._occupancy = occupancy
        self.map = (frame, occupied, unknown)

    def add_scan(
        self,
        pose: Pose2,
        hits_robot_m: FloatArray,
        misses_robot_m: FloatArray,
        stamp: float,
        view: FieldOfView = ALL_AROUND,
        *,
        source: str = "",
        proximity: bool = False,
    ) -> None:
        """Take a scan (points in the robot frame) of ``source`` (a lidar; with
        ``proximity``, a range sensor or a depth camera) seen from ``pose`` at ``stamp``,
        its rays covering ``view``: its hits join the live obstacle points (with the other
        sources' latest, those within ``LIVE_SCAN_S`` of it); its rays mark and clear its
        obstacle layer."""
        hits = pose.transform(hits_robot_m)
        self.live.add(source, stamp, hits, None if proximity else view)
        layer = self.proximity if proximity else self.obstacles
        if layer is not None:
            layer.add_scan((pose.x, pose.y), hits, pose.transform(misses_robot_m), stamp)

    def mark_spot(self, pose: Pose2, point_robot_m: tuple[float, float], until: float) -> None:
        """Mark where a bumper or a cliff sensor at ``point_robot_m`` on the robot at
        ``pose`` felt something, as a proximity obstacle kept until ``until`` [s] (then
        forgotten after the persistence time, as any mark)."""
        if self.proximity is not None:
            spot = pose.transform(np.array([point_robot_m], dtype=np.float64))
            self.proximity.add_scan((pose.x, pose.y), spot, np.empty((0, 2)), until)

    def set_robots(self, robots: tuple[tuple[str, float, float, float, float, float], ...]) -> None:
        """The fleet's other robots (``LivePoints.set_robots``): live points, and obstacles
        in the snapshots, until the next call."""
        self.live.set_robots(robots)

    @property
    def scan_points(self) -> FloatArray:
        """[m] the live obstacle points (``LivePoints``)."""
        return self.live.points

    @property
    def views(self) -> tuple[FieldOfView, ...]:
        """What the live lidars' rays covered."""
        return self.live.views

    def forget_around(self, x_m: float, y_m: float, radius_m: float) -> None:
        """Forget lidar obstacles within ``radius_m`` of (x_m, y_m) (stuck recovery; what a
        proximity sensor or a bumper felt stays until it expires)."""
        if self.obstacles is not None:
            self.obstacles.clear_disc(x_m, y_m, radius_m)

    def _memories(self) -> list[ObstacleLayer]:
        """The obstacle layers there are: the lidars', the proximity sensors'."""
        return [layer for layer in (self.obstacles, self.proximity) if layer is not None]

    def snapshot(
        self, now: float, points_m: list[tuple[float, float]]
    ) -> tuple[GridFrame, BoolArray, BoolArray]:
        """(frame, obstacle cells, unknown cells) of all layers at ``now``, on a frame holding
        the map, ``points_m`` (the robot, the goal) with a margin, and the scan obstacles
        still remembered.

        Raises:
            GoalRefusedError: that frame would hold more than ``max_cells`` cells.
        """
        frame = self._frame(points_m, now)
        limit = self.settings.max_cells
        if frame.rows * frame.cols > limit:
            res = frame.resolution_m
            raise GoalRefusedError(
                f"the area to plan over, {frame.cols * res:.0f} x {frame.rows * res:.0f} m "
                f"(the map, the robot and the goal), is {frame.rows * frame.cols} cells of "
                f"{res:g} m: more than planning.max_plan_cells ({limit})"
            )
        return self._layers_on(frame, now)

    def needs_window(
        self, now: float, robot_xy_m: tuple[float, float], goal_xy_m: tuple[float, float]
    ) -> bool:
        """True if a goal is planned in a window with a coarse route (``horizon``): the
        whole area would exceed ``max_cells``, or there is no map to plan the whole way on
        and the goal lies beyond the window."""
        frame = self._frame([robot_xy_m, goal_xy_m], now)
        if frame.rows * frame.cols > self.settings.max_cells:
            return True
        reach = self.settings.window_m / 2.0 - FRAME_MARGIN_M
        far = max(abs(goal_xy_m[0] - robot_xy_m[0]), abs(goal_xy_m[1] - robot_xy_m[1])) > reach
        return self.map is None and far

    def window_snapshot(
        self, now: float, center_xy_m: tuple[float, float]
    ) -> tuple[GridFrame, BoolArray, BoolArray]:
        """(frame, obstacle cells, unknown cells) of all layers at ``now`` in the square of
        side ``window_m`` around ``center_xy_m``, on the map's lattice."""
        half = self.settings.window_m / 2.0
        x, y = center_xy_m
        res, anchor = self._lattice()
        return self._layers_on(snap((x - half, y - half, x + half, y + half), res, anchor), now)

    def coarse_snapshot(
        self, now: float, points_m: list[tuple[float, float]], max_cells: int, min_cell_m: float
    ) -> tuple[GridFrame, BoolArray, BoolArray]:
        """(frame, obstacle cells, unknown cells) of the whole area (the map, ``points_m``,
        the scan obstacles remembered) on a coarse lattice: blocks of k x k cells, k the
        least that keeps the frame within ``max_cells`` with blocks at least ``min_cell_m``
        wide. A block is an obstacle if any of its cells is, known if any of its cells is."""
        fine = self._frame(points_m, now)
        res = fine.resolution_m
        k = max(
            math.ceil(round(min_cell_m / res, 6)),
            math.ceil(math.sqrt(fine.rows * fine.cols / max_cells)),
        )
        coarse = GridFrame(
            res * k,
            fine.origin_x_m,
            fine.origin_y_m,
            math.ceil(fine.rows / k),
            math.ceil(fine.cols / k),
        )
        obstacles = np.zeros(coarse.shape, dtype=np.bool_)
        unknown = np.ones(coarse.shape, dtype=np.bool_)
        if self.map is not None:
            map_frame, occupied, map_unknown = self.map
            obstacles |= pooled(coarse, k, map_frame, occupied)
            unknown &= ~pooled(coarse, k, map_frame, ~map_unknown)
        for layer in self._memories():
            if aligned(layer.frame, (fine.origin_x_m, fine.origin_y_m)):
                obstacles |= pooled(coarse, k, layer.frame, layer.active(now))
        obstacles |= self.keep_out(coarse)
        return coarse, obstacles, unknown

    def _layers_on(self, frame: GridFrame, now: float) -> tuple[GridFrame, BoolArray, BoolArray]:
        """(frame, obstacle cells, unknown cells) of all layers at ``now`` on ``frame`` (on
        the map's lattice); the obstacle layer follows it."""
        self.zones.refresh(now)
        self.zones.check()  # a keep-out zone that cannot be read cannot be kept out of
        obstacles = np.zeros(frame.shape, dtype=np.bool_)
        unknown = np.ones(frame.shape, dtype=np.bool_)
        if self.map is not None:
            map_frame, occupied, map_unknown = self.map
            inside = overlap(frame, map_frame)
            if inside is not None:
                outer, inner = inside
                obstacles[outer] = occupied[inner]
                unknown[outer] = map_unknown[inner]
        self.obstacles = _following(self.obstacles, frame, self.settings.obstacle_persistence_s)
        self.proximity = _following(self.proximity, frame, self.settings.proximity_persistence_s)
        obstacles |= self.obstacles.active(now) | self.proximity.active(now)
        obstacles |= self.keep_out(frame)
        if self.live.robot_points.shape[0]:
            cells = frame.cells_of(self.live.robot_points)
            within = (cells[:, 0] >= 0) & (cells[:, 0] < frame.rows)
            within &= (cells[:, 1] >= 0) & (cells[:, 1] < frame.cols)
            obstacles[cells[within, 0], cells[within, 1]] = True
        return frame, obstacles, unknown

    def keep_out(self, frame: GridFrame) -> BoolArray:
        """The keep-out cells of ``frame`` (the polygons' and the mask's), computed once per
        frame, set of polygons and reading of the mask."""
        zones = self.settings.keep_out_zones
        revision = self.zones.revision
        cached = self._keep_out
        if cached is None or cached[:3] != (frame, zones, revision):
            cells = keep_out_mask(frame, zones) | self.zones.keep_out_cells(frame)
            cached = (frame, zones, revision, cells)
            self._keep_out = cached
        return cached[3]

    def has_keep_out(self) -> bool:
        """True if any keep-out zone (a polygon or a mask) is set."""
        return bool(self.settings.keep_out_zones) or self.zones.keep_out is not None

    def local_points(self, pose: Pose2, radius_m: float, now: float) -> FloatArray:
        """[m] obstacle points near the robot: live scan hits; the scan obstacles still
        remembered at ``now`` where no live scan looks (what lidars that do not see all
        around saw on the way in, and see no more as the robot backs out); map and keep-out
        cells."""
        parts = [self.scan_points]
        if self.map is not None:
            frame, occupied, _ = self.map
            parts.append(cells_near(frame, occupied, pose, radius_m))
        layer = self.obstacles
        if layer is not None:
            window = window_around(layer.frame, pose, radius_m)
            if window is not None and not any(v.all_around for v in self.views):
                remembered = layer.last_seen[window] >= now - layer.persistence_s
                marks = cells_of(layer.frame, remembered, window)
                local = pose.inverse().transform(marks)
                unseen = self.views[0].unseen(local)
                for view in self.views[1:]:
                    unseen &= view.unseen(local)
                parts.append(marks[unseen])
            if self.has_keep_out():
                frame = layer.frame
                parts.append(cells_near(frame, self.keep_out(frame), pose, radius_m))
        near = self.proximity  # what proximity sensors felt, wherever lidars look
        if near is not None:
            window = window_around(near.frame, pose, radius_m)
            if window is not None:
                felt = near.last_seen[window] >= now - near.persistence_s
                parts.append(cells_of(near.frame, felt, window))
        return np.concatenate(parts) if len(parts) > 1 else parts[0]

    def _lattice(self) -> tuple[float, tuple[float, float]]:
        """([m] cell size, [m] a cell corner) of the lattice every snapshot lies on: the
        map's, else the obstacle layer's, else the default's through the origin."""
        if self.map is not None:
            m = self.map[0]
            return m.resolution_m, (m.origin_x_m, m.origin_y_m)
        if self.obstacles is not None:
            o = self.obstacles.frame
            return o.resolution_m, (o.origin_x_m, o.origin_y_m)
        return DEFAULT_RESOLUTION_M, (0.0, 0.0)

    def _frame(self, points_m: list[tuple[float, float]], now: float) -> GridFrame:
        """The map's frame grown in whole cells to hold ``points_m`` with a margin, and the
        scan obstacles still remembered at ``now`` (a frame grown once for a far goal
        shrinks again when its marks expire)."""
        res, anchor = self._lattice()
        xs = [p[0] for p in points_m]
        ys = [p[1] for p in points_m]
        lo_x, hi_x = min(xs) - FRAME_MARGIN_M, max(xs) + FRAME_MARGIN_M
        lo_y, hi_y = min(ys) - FRAME_MARGIN_M, max(ys) + FRAME_MARGIN_M
        if self.map is not None:
            m = self.map[0]
            lo_x, lo_y = min(lo_x, m.origin_x_m), min(lo_y, m.origin_y_m)
            hi_x, hi_y = (
                max(hi_x, m.origin_x_m + m.cols * res),
                max(hi_y, m.origin_y_m + m.rows * res),
            )
        for layer in self._memories():
            if layer.frame.resolution_m == res and aligned(layer.frame, anchor):
                marks = layer.active_bounds(now)
                if marks is not None:
                    lo_x, lo_y = min(lo_x, marks[0]), min(lo_y, marks[1])
                    hi_x, hi_y = max(hi_x, marks[2]), max(hi_y, marks[3])
        return snap((lo_x, lo_y, hi_x, hi_y), res, anchor)


def _following(
    layer: ObstacleLayer | None, frame: GridFrame, persistence_s: float
) -> ObstacleLayer:
    """``layer`` moved onto ``frame``, keeping its marks where they overlap; a new layer
    when there is none, or the frame is on another lattice (a new map: the short-lived
    marks start afresh)."""
    if layer is not None:
        try:
            layer.reframe(frame)
            return layer
        except ValueError:
            pass
    return ObstacleLayer(frame, persistence_s)
