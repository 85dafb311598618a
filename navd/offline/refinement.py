"""The reported pose refined on the fine map: the field each matched scan is searched again
on, and when that field is drawn anew or brought up to date (``fine_map`` says why the pose
is refined, and what it changes).

The field is drawn anew when the robot has moved ``FIELD_MARGIN_M`` from its centre, or the
fine map was drawn anew (after a re-solve of the pose graph, or past its budget of tiles),
and brought up to date with each keyframe drawn in between (``FineMap.update``): docs/slam.md
(pipeline step 6) gives what the other choices cost.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from navd.geometry import Pose2
from navd.offline.fine_map import FineMap, fine_keep_cells, fine_refiner, refine_pose
from navd.slam import Keyframe, LikelihoodField, MapperSettings, OccupancyGrid

__all__ = ["FIELD_MARGIN_M", "FineRefinement"]

FloatArray = npt.NDArray[np.float64]

# The field reaches this far [m] beyond the scans' range and the refinement's window, and is
# drawn anew when the robot has moved this far from its centre.
FIELD_MARGIN_M = 1.0


class FineRefinement:
    """Matched poses refined on a fine map of the keyframes near the robot (a
    ``slam.reported_pose.PoseRefiner``).

    Args:
        settings: the mapper's; half the lidar's range is the fine map's reach (fixed for
            its life).
        cell_m: [m] the fine map's cell (fixed for its life).
    """

    def __init__(self, settings: MapperSettings, cell_m: float) -> None:
        s = settings
        self.map = FineMap(cell_m, s.max_range_m / 2, fine_keep_cells(s.resolution_m, cell_m))
        self.configure(settings)
        self._field: LikelihoodField | None = None
        self._grid: OccupancyGrid | None = None  # the fine map's grid it was drawn from
        self._revision = -1  # that grid's revision when it was drawn or brought up to date
        self._center = Pose2(0.0, 0.0, 0.0)  # where it was drawn around

    @classmethod
    def of(cls, settings: MapperSettings, cell_m: float) -> FineRefinement | None:
        """A refinement on cells of ``cell_m`` [m] where one can be had: cells finer than
        the map's, and keyframes that keep their scans (loop closure on) to draw them
        from; None otherwise. (The daemon refines nothing: docs/slam.md, pipeline step 6,
        says why.)"""
        if not settings.loop_closure or cell_m >= settings.resolution_m:
            return None
        return cls(settings, cell_m)

    def configure(self, settings: MapperSettings) -> None:
        """Take new settings (the refinement's pull, the blur, the range)."""
        self.settings = settings
        self.matcher = fine_refiner(settings)

    def add(self, keyframes: Sequence[Keyframe]) -> None:
        """Draw the newest keyframe into the fine map."""
        self.map.add(keyframes)

    def clear(self) -> None:
        """Forget every keyframe drawn (their poses moved, or they were replaced)."""
        self.map.clear()

    def refine(self, keyframes: Sequence[Keyframe], points: FloatArray, pose: Pose2) -> Pose2:
        """``pose`` (a scan's match on the map; ``points`` the scan, robot frame, N x 2 [m])
        searched again on the fine map of ``keyframes`` near it."""
        s = self.settings
        fine = self.map
        moved = np.hypot(pose.x - self._center.x, pose.y - self._center.y)
        if self._field is None or self._grid is not fine.grid or moved > FIELD_MARGIN_M:
            radius = s.max_range_m + s.resolution_m + FIELD_MARGIN_M
            self._field = fine.field(keyframes, pose, radius, s.blur_sigma_m)
            self._grid = fine.grid  # (drawn anew if it had grown too large)
            self._revision = fine.grid.revision
            self._center = pose
        elif self._revision != fine.grid.revision:
            self._field = fine.update(keyframes, pose, self._field, s.blur_sigma_m)
            self._revision = fine.grid.revision
        return refine_pose(self.matcher, self._field, points, pose)
