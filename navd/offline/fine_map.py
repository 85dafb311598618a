"""The fine map: the keyframes near the robot drawn again at a finer cell than the map's, on
which each tracked pose is refined before it is reported (a replay's trajectory; the daemon
reports the match itself, docs/slam.md, pipeline step 6, says why and what was measured).

A grid places each wall in the cell its rays end in, so a match on a 5 cm map is as coarse as
its cells; drawn again at 2.5 cm, a scan's position is found again nearer where it was taken.
Only the reported pose changes: tracking, the map, the keyframes and the loop closures go on
from the match on the map.

The refinement searches positions within one map cell of the match and headings within
``REFINE_YAW_RAD`` of it, pulled toward the match as tracking pulls toward the odometry, and
along the scan's weak axis with ``REFINE_AXIS_SHARE`` of tracking's extra pull there.

Memory and time: the map draws only the keyframes within half the lidar's range of the robot,
keeps what it drew while the robot moves on, and is drawn anew around the robot (one keyframe
per place: ``THIN_CELL_M``, ``THIN_YAW_RAD``) when it grows past ``max_tiles`` tiles or after
a re-solve of the pose graph. The field the refinement reads is drawn anew only when the
mapper asks (``refinement``) and brought up to date with each new keyframe's hits in between
(``update``); each field handed out shares its cells with the next: ``field`` and ``update``
write into the last one's array, so a field is good until the next call.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from navd.geometry import Pose2
from navd.slam import CorrelativeMatcher, Keyframe, LikelihoodField, MapperSettings, OccupancyGrid

FloatArray = npt.NDArray[np.float64]

__all__ = ["MAX_TILES", "FineMap", "fine_keep_cells", "fine_refiner", "refine_pose"]

# Tiles this map may grow to before it is drawn anew around the robot (64 x 64 float32
# cells, 16 KB each: 6 MB; docs/slam.md, pipeline step 6, gives the peaks of other sizes).
MAX_TILES = 384
# The refinement's search: headings within this of the match [rad] (0.29 degrees, about
# half the tracking's rotation step), in steps of half of it.
REFINE_YAW_RAD = 0.005
# ... pulled toward the match along the scan's weak axis with this share of the tracking's
# extra pull there (``slam.prior_axis_weight_per_m2``).
REFINE_AXIS_SHARE = 0.5
# When the map is drawn anew (after a re-solve of the pose graph, or past ``max_tiles``), one
# keyframe is drawn per place: a square of this side [m] and this much heading [rad] (the
# passes through a place see the same walls).
THIN_CELL_M = 0.5
THIN_YAW_RAD = math.pi / 4


def fine_keep_cells(resolution_m: float, cell_m: float) -> int:
    """Cells short of a hit where a ray on a fine map (cells of ``cell_m`` [m]) stops
    freeing: the fine cells of one map cell (``resolution_m`` [m]) beside the end's own (1 at
    half the map's cell)."""
    return max(0, round(resolution_m / cell_m) - 1)


def fine_refiner(settings: MapperSettings) -> CorrelativeMatcher:
    """The refinement's search: positions within one map cell of the match and headings
    within ``REFINE_YAW_RAD`` of it, pulled toward it as the module docstring says."""
    return CorrelativeMatcher(
        search_xy_m=settings.resolution_m,
        search_yaw_rad=REFINE_YAW_RAD,
        angle_step_rad=REFINE_YAW_RAD / 2,
        levels=0,  # a window of 5 x 5 cells: every cell is scored, no sliding maxima kept
        prior_weight_per_m2=settings.prior_weight_per_m2,
        prior_axis_weight_per_m2=REFINE_AXIS_SHARE * settings.prior_axis_weight_per_m2,
        point_spacing_m=settings.voxel_size_m,
    )


def refine_pose(
    refiner: CorrelativeMatcher, field: LikelihoodField, points: FloatArray, pose: Pose2
) -> Pose2:
    """Where ``points`` (robot frame, N x 2 [m]) fit ``field`` best within the refiner's
    window around ``pose``."""
    found = refiner.match(field, points, pose).pose
    return Pose2(float(found.x), float(found.y), float(found.yaw))


class FineMap:
    """The keyframes near the robot, drawn on a grid of their own at a finer cell.

    Args:
        resolution_m: [m] its cell size.
        reach_m: [m] keyframes within this of a field's centre are drawn for it.
        keep_cells: see ``OccupancyGrid``.
        max_tiles: tiles it may hold before it is drawn anew with only what is near.
    """

    def __init__(
        self, resolution_m: float, reach_m: float, keep_cells: int, max_tiles: int = MAX_TILES
    ) -> None:
        self.resolution_m = resolution_m
        self.reach_m = reach_m
        self.keep_cells = keep_cells
        self.max_tiles = max_tiles
        self.grid = OccupancyGrid(resolution_m, keep_cells=keep_cells)
        self.redraws = 0  # times it was drawn anew to stay within max_tiles
        # Per keyframe known so far: its position [m], whether it can be drawn, whether it
        # is drawn, whether it was left out as one of a place drawn already (``_thin``),
        # and its heading [rad].
        self._xy = np.zeros((0, 2))
        self._usable = np.zeros(0, dtype=bool)
        self._drawn = np.zeros(0, dtype=bool)
        self._skipped = np.zeros(0, dtype=bool)
        self._yaw = np.zeros(0)
        self._values: npt.NDArray[np.float32] | None = None  # the last field's cells
        # Hits [m, map frame] of the keyframes drawn since the last field was drawn or
        # brought up to date (``update``).
        self._pending: list[FloatArray] = []

    def clear(self) -> None:
        """Forget every keyframe drawn (their poses moved, or the keyframes were replaced)."""
        self._empty()
        self._xy = np.zeros((0, 2))
        self._usable = np.zeros(0, dtype=bool)
        self._drawn = np.zeros(0, dtype=bool)
        self._skipped = np.zeros(0, dtype=bool)
        self._yaw = np.zeros(0)

    def _empty(self) -> None:
        """A new, empty grid (its revision past the old one's, so a field of the old grid
        reads as stale), every keyframe to be drawn again."""
        revision = self.grid.revision + 1
        self.grid = OccupancyGrid(self.resolution_m, keep_cells=self.keep_cells)
        self.grid.revision = revision
        self._drawn[:] = False
        self._skipped[:] = False
        self._pending = []

    def add(self, keyframes: Sequence[Keyframe]) -> None:
        """Draw the newest keyframe (where the robot is)."""
        self._learn(keyframes)
        if self.grid.cells_store.used[0] > self.max_tiles:
            # Grown too large along the way: the next field draws what is near anew.
            self._empty()
            self.redraws += 1
        self._draw(keyframes, len(keyframes) - 1)

    def field(
        self,
        keyframes: Sequence[Keyframe],
        center: Pose2,
        radius_m: float,
        sigma_m: float,
    ) -> LikelihoodField:
        """The likelihood field within ``radius_m`` [m] of ``center`` (see
        ``OccupancyGrid.likelihood_field``; ``sigma_m`` [m] its blur), every keyframe within
        ``reach_m`` of the centre drawn first (one per place if the map was drawn anew).
        Drawn in the last field's array: that field is no longer good."""
        close = self._close(keyframes, center)
        missing = np.flatnonzero(close & ~self._drawn & ~self._skipped)
        if missing.size and self.grid.cells_store.used[0] > self.max_tiles:
            self._empty()
            self.redraws += 1
            missing = np.flatnonzero(close)
        for i in self._thin(missing):  # in the order they were made, as the map draws them
            self._draw(keyframes, int(i))
        # Drawn in the last field's array: a new array for each fragments the heap.
        field = self.grid.likelihood_field(center, radius_m, sigma_m, out=self._values)
        self._values = field.values
        self._pending = []
        return field

    def update(
        self,
        keyframes: Sequence[Keyframe],
        center: Pose2,
        field: LikelihoodField,
        sigma_m: float,
    ) -> LikelihoodField:
        """``field`` (the last from ``field``, with ``sigma_m`` [m]) brought up to date: the
        keyframes within ``reach_m`` of ``center`` not drawn yet are drawn (one per place),
        and the hits of every keyframe drawn since are stamped in
        (``OccupancyGrid.stamp_points``: cells a keyframe freed stay stamped until the field
        is drawn anew): a small part of drawing the field anew. Stamped into ``field``'s
        array; returned as a new field (no bounds cached), or ``field`` itself if nothing was
        drawn since.

        The grid must be the one ``field`` was drawn from: after ``clear``, or a redraw
        within ``max_tiles``, draw the field anew instead.
        """
        close = self._close(keyframes, center)
        for i in self._thin(np.flatnonzero(close & ~self._drawn & ~self._skipped)):
            self._draw(keyframes, int(i))
        if not self._pending:
            return field
        hits = np.concatenate(self._pending)
        self._pending = []
        return self.grid.stamp_points(field, hits, sigma_m)

    def _close(self, keyframes: Sequence[Keyframe], center: Pose2) -> npt.NDArray[np.bool_]:
        """Which keyframes (all made so far, learnt first) can be drawn and lie within
        ``reach_m`` of ``center``."""
        self._learn(keyframes)
        xy = self._xy
        near = np.hypot(xy[:, 0] - center.x, xy[:, 1] - center.y) <= self.reach_m
        return near & self._usable

    def _draw(self, keyframes: Sequence[Keyframe], index: int) -> None:
        """Draw keyframe ``index`` if it can be and is not yet; note its hits [m] for the
        next ``update``."""
        frame = keyframes[index]
        if self._usable[index] and not self._drawn[index]:
            assert frame.scan is not None
            self.grid.insert(frame.pose, frame.scan)
            self._drawn[index] = True
            self._pending.append(frame.pose.transform(frame.scan.hits))

    def _learn(self, keyframes: Sequence[Keyframe]) -> None:
        """Note the keyframes made since the last call: their positions, once each."""
        known = self._usable.size
        if len(keyframes) > known:
            new = keyframes[known:]
            self._xy = np.concatenate([self._xy, [(f.pose.x, f.pose.y) for f in new]])
            self._usable = np.concatenate(
                [self._usable, [f.scan is not None and f.mapped for f in new]]
            )
            self._drawn = np.concatenate([self._drawn, np.zeros(len(new), dtype=bool)])
            self._skipped = np.concatenate([self._skipped, np.zeros(len(new), dtype=bool)])
            self._yaw = np.concatenate([self._yaw, [f.pose.yaw for f in new]])

    def _thin(self, missing: npt.NDArray[np.intp]) -> list[int]:
        """Of the keyframes ``missing`` (indices, oldest first), those to draw: the newest
        of each place (``THIN_CELL_M`` square, ``THIN_YAW_RAD`` of heading) where none is
        drawn yet, oldest first; the others are marked skipped until the map is drawn anew."""
        if missing.size == 0:
            return []

        def place(i: int) -> tuple[int, int, int]:
            x, y = self._xy[i]
            return (
                math.floor(x / THIN_CELL_M),
                math.floor(y / THIN_CELL_M),
                math.floor(self._yaw[i] / THIN_YAW_RAD),
            )

        taken = {place(int(i)) for i in np.flatnonzero(self._drawn)}
        keep = []
        for i in missing[::-1]:
            key = place(int(i))
            if key in taken:
                self._skipped[i] = True
            else:
                taken.add(key)
                keep.append(int(i))
        return keep[::-1]
