"""The likelihood field scans are matched on: drawn from the map around the robot's predicted
pose, as far as the lidar reaches and the search window goes, and used again for the scans
after it while the map has not changed and the robot is within a quarter of the lidar's
range of where it was drawn."""

from __future__ import annotations

import numpy as np

from navd.geometry import Pose2
from navd.slam.likelihood_field import LikelihoodField
from navd.slam.occupancy import OccupancyGrid
from navd.slam.settings import MapperSettings

__all__ = ["TrackingField"]


class TrackingField:
    """The field in use, and where and from which map revision it was drawn."""

    def __init__(self) -> None:
        self._field: LikelihoodField | None = None
        self._revision = -1
        self._center = Pose2(0.0, 0.0, 0.0)

    def forget(self) -> None:
        """Let go of the field (new settings, a new map, or its memory is wanted back)."""
        self._field = None

    def around(
        self, grid: OccupancyGrid, prior: Pose2, s: MapperSettings
    ) -> tuple[LikelihoodField, bool]:
        """The field for matching near ``prior`` on ``grid``, and whether it was drawn anew."""
        reach = s.max_range_m + s.search_xy_m
        stale = self._field is None or self._revision != grid.revision
        moved = np.hypot(prior.x - self._center.x, prior.y - self._center.y)
        drawn = stale or moved > s.max_range_m * 0.25
        if drawn:
            radius = reach + s.max_range_m * 0.25
            self._field = grid.likelihood_field(prior, radius, s.blur_sigma_m)
            self._revision = grid.revision
            self._center = prior
        assert self._field is not None
        return self._field, drawn
