"""Doubt and repair: judging a scan match on mapped ground against the recent ones, and the
wider search that finds a robot further off than the tracking window.

A match whose fit (mean likelihood under the scan points that land on mapped ground) is below
``FIT_DROP_RATIO`` of the median of the last ``RECENT_FITS`` matched scans is doubtful; so is
any scan that does not match after ``LOST_RUN`` that did not either. Both are searched for
again in a wider window (``REPAIR_XY_M``, ``REPAIR_YAW_RAD``): wheels that slipped, a robot
back on old ground further off than the window. The wider match must fit at least
``loop_min_score`` (and, for a doubtful one, ``REPAIR_MARGIN`` better than the match) on at
least ``REPAIR_KNOWN_FRACTION`` of the points, and be unambiguous (no translation farther than
``REPAIR_RIVAL_EXCLUDE_M`` but within ``REPAIR_XY_M`` scoring ``REPAIR_MAX_RIVAL_RATIO`` of
it). If it is not found, a doubtful match stands, counted (people walking by, a door opened).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Protocol

import numpy as np
import numpy.typing as npt

from navd.geometry import Pose2
from navd.slam.likelihood_field import LikelihoodField
from navd.slam.matcher import CorrelativeMatcher, Match, rival_ratio
from navd.slam.occupancy import OccupancyGrid
from navd.slam.settings import MapperSettings

__all__ = [
    "LOST_KNOWN_FRACTION",
    "LOST_RUN",
    "MIN_KNOWN_POINTS",
    "REPAIR_KNOWN_FRACTION",
    "ROBOT_CELL",
    "MatchRepair",
]

FloatArray = npt.NDArray[np.float64]

# A match is judged on the scan points that land on mapped cells: at least this many of them.
MIN_KNOWN_POINTS = 10
# A scan with at least this share of its points (and MIN_KNOWN_POINTS) on mapped ground that
# does not fit there counts toward being lost (``lost_after_scans``): a robot carried off sees
# its walls where the map has open floor, or none at all.
LOST_KNOWN_FRACTION = 0.25
ROBOT_CELL = np.zeros((1, 2))  # the robot's own position, in its frame
# After this many scans in a row that did not match, the next that does not is searched for
# again (and every keyframe searches for a loop): a robot back on old ground after drifting.
LOST_RUN = 3
REPAIR_KNOWN_FRACTION = 0.5
REPAIR_XY_M, REPAIR_YAW_RAD = 2.0, 0.25
REPAIR_RIVAL_EXCLUDE_M, REPAIR_MAX_RIVAL_RATIO = 0.3, 0.9
FIT_DROP_RATIO, RECENT_FITS, REPAIR_MARGIN = 0.7, 20, 0.2


class RepairCounts(Protocol):
    """The mapper's counts this module adds to."""

    doubtful: int
    repaired: int
    repair_ambiguous: int


class MatchRepair:
    """The recent fits, and the wider search of a doubtful or unmatched scan.

    Args:
        settings: the mapper's (``min_score``, ``loop_min_score``, ``max_range_m``).
        counts: where doubtful, repaired and ambiguous repairs are counted.
    """

    def __init__(self, settings: MapperSettings, counts: RepairCounts) -> None:
        self.counts = counts
        self._fits = np.zeros(RECENT_FITS)  # the last matched scans' fits (a ring)
        self.configure(settings)

    def configure(self, settings: MapperSettings) -> None:
        """Take new settings; fits on the old settings' field are no yardstick for the new."""
        self.settings = settings
        self.wide_matcher = CorrelativeMatcher(
            search_xy_m=REPAIR_XY_M, search_yaw_rad=REPAIR_YAW_RAD, reach_m=settings.max_range_m / 2
        )
        self._fits_seen = 0

    def record(self, fit: float) -> None:
        """A scan matched with ``fit``: one of the recent fits."""
        self._fits[self._fits_seen % self._fits.size] = fit
        self._fits_seen += 1

    def recent_fit(self) -> float:
        """The median fit of the last matched scans (0 before any)."""
        n = min(self._fits_seen, self._fits.size)
        return float(np.median(self._fits[:n])) if n else 0.0

    def check(
        self,
        grid: OccupancyGrid,
        field_at: Callable[[Pose2], LikelihoodField],
        points: FloatArray,
        *,
        prior: Pose2,
        match: Match,
        known: float,
        weak_run: int,
    ) -> tuple[Match, float, bool]:
        """A match on mapped ground, searched for again if in doubt: (match, known fraction,
        doubtful)."""
        s = self.settings
        fit = match.score / known if known > 0.0 else 0.0
        lost = fit < s.min_score and weak_run >= LOST_RUN
        dropped = fit >= s.min_score and fit < FIT_DROP_RATIO * self.recent_fit()
        if not (lost or dropped):
            return match, known, False
        better = s.loop_min_score if lost else max(s.loop_min_score, fit + REPAIR_MARGIN)
        repaired = self._repair(grid, field_at(prior), points, prior, better)
        if repaired is not None:
            return (*repaired, False)
        if dropped:
            self.counts.doubtful += 1
        return match, known, dropped

    def _repair(
        self,
        grid: OccupancyGrid,
        field: LikelihoodField,
        points: FloatArray,
        prior: Pose2,
        min_fit: float,
    ) -> tuple[Match, float] | None:
        """The scan's pose in a wider window around ``prior`` if it fits there at least
        ``min_fit`` and unambiguously, with its known fraction; None otherwise."""
        match = self.wide_matcher.match(field, points, prior)
        known = grid.known_fraction(match.pose, points)
        enough = known >= REPAIR_KNOWN_FRACTION and known * points.shape[0] >= MIN_KNOWN_POINTS
        if not enough or match.score / known < min_fit:
            return None
        rival = rival_ratio(
            field, points, match.pose, radius_m=REPAIR_XY_M, exclude_m=REPAIR_RIVAL_EXCLUDE_M
        )
        if rival > REPAIR_MAX_RIVAL_RATIO:
            self.counts.repair_ambiguous += 1
            return None
        self.counts.repaired += 1
        return match, known
