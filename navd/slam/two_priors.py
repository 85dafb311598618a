"""Two priors for one scan: the odometry's prediction and the last step taken again.

An encoder glitch (a wheel that slipped, a counter that jumped) puts the odometry's
prediction where the robot is not; a log whose stamps lie makes a true step look like one no
robot makes. When the odometry's step is beyond ``slam.plausible_*`` the mapper predicts
both: the last tracked step taken again (``MotionCheck.coasted``), matched first, and the
odometry's, taken only if the scan fits it clearly better (``SPIKE_MARGIN``): down a corridor
a spike fits as well as the truth, and then the plausible one stands.

(Matching around the coasted prediction also where a plausible odometry step put a scan's
part on mapped ground where it does not fit found a 1.5 rad glitch between scans 0.6 s apart,
but on the robustness suite it took the coasted one wrongly too: fr-clinic with worse wheels
1.93 m against 0.127 m, aces with range noise 0.215 m against 0.050 m. Not kept.)
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import numpy.typing as npt

from navd.geometry import Pose2
from navd.slam.likelihood_field import LikelihoodField
from navd.slam.matcher import CorrelativeMatcher, Match

__all__ = ["SPIKE_MARGIN", "match_either"]

FloatArray = npt.NDArray[np.float64]

# The other prior is taken only if the scan fits it this much better (scores are in [0, 1]).
SPIKE_MARGIN = 0.05


def match_either(
    matcher: CorrelativeMatcher,
    field_around: Callable[[Pose2], LikelihoodField],
    points: FloatArray,
    prior: Pose2,
    odometry: Pose2 | None,
) -> tuple[Match, Pose2, bool]:
    """(match, its prior, whether the odometry's step was a spike) for ``points`` (robot
    frame, downsampled) matched on ``field_around`` the ``prior``: the coasted prediction
    when ``odometry`` is the odometry's implausible one (see the module docstring), else
    the prediction, alone."""
    match = matcher.match(field_around(prior), points, prior)
    if odometry is None:
        return match, prior, False
    second = matcher.match(field_around(odometry), points, odometry)
    if second.score <= match.score + SPIKE_MARGIN:
        return match, prior, True
    return second, odometry, False
