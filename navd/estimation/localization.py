"""How well the robot knows where it is: uninitialized, ok, degraded or lost, by the spread
of the estimate's position (``estimation.degraded_position_std_m``, ``lost_position_std_m``)."""

from __future__ import annotations

import math

from navd.config import EstimationConfig
from navd.lifecycle.messages import PoseEstimate

__all__ = ["Localization", "largest_eigenvalue", "localization_of"]


class Localization:
    """Names of the localization states."""

    UNINITIALIZED = "uninitialized"
    OK = "ok"
    DEGRADED = "degraded"
    LOST = "lost"


def localization_of(
    estimate: PoseEstimate | None, est: EstimationConfig
) -> tuple[str, float, float]:
    """(state, position std [m], yaw std [rad]) of ``estimate``: the position's spread is
    the larger axis of its covariance ellipse."""
    if estimate is None:
        return Localization.UNINITIALIZED, math.inf, math.inf
    cov = estimate.covariance
    position_std = math.sqrt(max(largest_eigenvalue(cov[0, 0], cov[0, 1], cov[1, 1]), 0.0))
    yaw_std = math.sqrt(max(float(cov[2, 2]), 0.0))
    if not position_std <= est.lost_position_std_m:  # a spread that is not a number too
        return Localization.LOST, position_std, yaw_std
    if position_std > est.degraded_position_std_m:
        return Localization.DEGRADED, position_std, yaw_std
    return Localization.OK, position_std, yaw_std


def largest_eigenvalue(a: float, b: float, d: float) -> float:
    """The larger eigenvalue of the symmetric 2 x 2 matrix [[a, b], [b, d]] (closed form: at
    20 Hz on the event loop, a LAPACK call costs more than the rest of the estimate)."""
    half_trace = 0.5 * (float(a) + float(d))
    return half_trace + math.hypot(0.5 * (float(a) - float(d)), float(b))
