"""Two priors for one scan: the odometry's prediction and the last step taken again.

An encoder glitch (a wheel that slipped, a counter that jumped) puts the odometry's
prediction where the robot is not; a log whose stamps lie makes a true step look like one no
robot makes. The mapper predicts both: the odometry's, and the last tracked step taken again
(``MotionCheck.coasted``). It matches around the plausible one first (the odometry's unless
its step is beyond ``slam.plausible_*``), and around the other where that first is not the
odometry's, or where the scan's part on mapped ground does not fit around it. The other is
taken only if the scan fits it clearly better (``SPIKE_MARGIN``): down a corridor a spike fits
as well as the truth, and then the plausible one stands. A scan of new ground, or a prior off
the map, is judged as before (new ground, or dropped): there the two cannot be told apart.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import numpy.typing as npt

from navd.geometry import Pose2
from navd.slam.likelihood_field import LikelihoodField
from navd.slam.match_repair import LOST_KNOWN_FRACTION, MIN_KNOWN_POINTS, ROBOT_CELL
from navd.slam.matcher import CorrelativeMatcher, Match
from navd.slam.occupancy import OccupancyGrid

__all__ = ["SPIKE_MARGIN", "match_either"]

FloatArray = npt.NDArray[np.float64]

# The other prior is taken only if the scan fits it this much better (scores are in [0, 1]).
SPIKE_MARGIN = 0.05


def match_either(
    matcher: CorrelativeMatcher,
    field_around: Callable[[Pose2], LikelihoodField],
    grid: OccupancyGrid,
    points: FloatArray,
    *,
    min_score: float,
    prior: Pose2,
    other: Pose2 | None,
    by_odometry: bool,
) -> tuple[Match, Pose2, bool, bool]:
    """(match, its prior, whether that is the odometry's, whether an odometry step was not
    followed: a spike) for ``points`` (robot frame, downsampled) matched on ``field_around``
    the priors (see the module docstring)."""
    match = matcher.match(field_around(prior), points, prior)
    if other is None:
        return match, prior, by_odometry, False
    if by_odometry:
        known = grid.known_fraction(match.pose, points)
        misfit = (
            known * points.shape[0] >= MIN_KNOWN_POINTS
            and known >= LOST_KNOWN_FRACTION
            and match.score / known < min_score
            and grid.known_fraction(prior, ROBOT_CELL) == 1.0
        )
        if not misfit:
            return match, prior, True, False
    second = matcher.match(field_around(other), points, other)
    if second.score <= match.score + SPIKE_MARGIN:
        return match, prior, by_odometry, not by_odometry
    return second, other, not by_odometry, by_odometry
