"""How much to trust the odometry's heading, learned from the scans matched so far.

The tracking matcher weighs each candidate pose against the odometry's prediction (see
``navd.slam.matcher``). How hard it should pull depends on the robot: the Freiburg clinic's
wheels turn 0.08° wrong per scan (median), the Intel lab's 0.36°, and a pull that holds the
clinic's long bare corridors straight bends the Intel map, while one that suits the Intel lab
lets the clinic's corridors curl. So the pull is not a setting but a measurement: every
matched scan says how far the odometry's heading was off over that step, and the weight
follows from the spread of the last ``WINDOW`` of those errors.

The spread is robust (1.4826 times the median absolute error), so the few wrong matches that
slip through and the turns where the wheels slip barely move it. The weight is
``WEIGHT_PER_PRECISION / sigma²`` (a Gaussian prior's log-likelihood, scaled into the
matcher's mean-score units), bounded to ``[MIN_WEIGHT, MAX_WEIGHT]``; until ``MIN_SAMPLES``
errors are known it is ``START_WEIGHT``.

The floor matters more than it looks. Each error is the odometry's step less the matched
step, so the matcher's own heading noise is in the spread too, and it grows with the
lidar's range noise: without a floor a noisy lidar lowers the weight until the prior pulls
too little to hold a fast turn. The floor (a sigma of about 0.5° per scan) keeps that pull
(docs/slam.md, "Measured history", gives the replays that chose it). The price: a robot
whose wheels are much worse than that gets a stronger heading prior than its odometry
merits.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["HeadingTrust"]

WINDOW = 400  # matched scans the spread is taken over
MIN_SAMPLES = 50  # errors needed before the measured weight is used
START_WEIGHT = 5.0  # [1/rad^2] weight before then
# [1] weight = this / sigma² [rad²]; set on the Freiburg logs, whose replays end with weights
# of 70 (fr-clinic), 43 (aces) and 7.5 (intel from the bag; 6.5 before the floor).
WEIGHT_PER_PRECISION = 4.5e-4
MIN_WEIGHT, MAX_WEIGHT = 5.0, 200.0  # [1/rad^2] (the floor: see the module docstring)
MAD_TO_SIGMA = 1.4826  # a Gaussian's sigma per median absolute deviation


class HeadingTrust:
    """The heading prior's weight [1/rad²], from the odometry's measured heading errors."""

    def __init__(self) -> None:
        self._errors = np.zeros(WINDOW, dtype=np.float64)
        self._count = 0

    @property
    def samples(self) -> int:
        """How many errors the weight rests on (at most ``WINDOW``)."""
        return min(self._count, WINDOW)

    def record(self, error_rad: float) -> None:
        """One matched scan's heading minus the odometry's prediction of it [rad]."""
        self._errors[self._count % WINDOW] = abs(math.remainder(error_rad, 2.0 * math.pi))
        self._count += 1

    def sigma_rad(self) -> float | None:
        """[rad] robust spread of the odometry's heading error per scan (None: too few)."""
        if self._count < MIN_SAMPLES:
            return None
        return MAD_TO_SIGMA * float(np.median(self._errors[: self.samples]))

    def weight_per_rad2(self) -> float:
        """[1/rad²] the mean match score a candidate loses per squared radian it turns from
        the odometry's prediction."""
        sigma = self.sigma_rad()
        if sigma is None:
            return START_WEIGHT
        if sigma <= 0.0:
            return MAX_WEIGHT
        return min(MAX_WEIGHT, max(MIN_WEIGHT, WEIGHT_PER_PRECISION / sigma**2))
