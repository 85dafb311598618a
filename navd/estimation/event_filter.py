"""The pose filter's event history as the estimator drives it: started at a pose with a
covariance for the rest of the state, events inserted with their rejections, resets and
late arrivals logged, and the pose at a past time (``history`` keeps the events)."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from navd.config import EstimationConfig
from navd.estimation.beacon_map import RobotPose
from navd.estimation.history import Event, EventHistory, HistorySettings, Insert
from navd.estimation.motion_model import STATE_SIZE, TH, VTH, X, Y, transition_matrix
from navd.estimation.ukf import MAX_YAW_STD_RAD, PoseUkf
from navd.geometry import wrap_angle
from navd.logs import get_logger

__all__ = ["EventFilter"]

FloatArray = npt.NDArray[np.float64]
_POSE = np.ix_((X, Y, TH), (X, Y, TH))
_log = get_logger("estimation")


class EventFilter(EventHistory):
    """An ``EventHistory`` of the 9-state pose filter.

    Args:
        ukf, settings: as ``EventHistory``'s.
        estimation: the noises a start gives the velocities and accelerations (replaced
            whole with the settings).
    """

    def __init__(
        self, ukf: PoseUkf, settings: HistorySettings, estimation: EstimationConfig
    ) -> None:
        super().__init__(ukf, settings)
        self.estimation = estimation

    def start(self, stamp: float, x: float, y: float, yaw: float, cov3: FloatArray) -> None:
        """Start (or restart) at (``x``, ``y``, ``yaw``) [m, m, rad] with that pose's 3 x 3
        covariance; velocities and accelerations unknown within the configured noises."""
        est = self.estimation
        state = np.zeros(STATE_SIZE)
        state[X], state[Y], state[TH] = x, y, wrap_angle(yaw)
        variances = np.full(STATE_SIZE, est.initial_velocity_std_mps**2)
        variances[[4, 5]] = est.accel_noise_mps2**2
        variances[[VTH]] = 0.5**2
        variances[[8]] = est.angular_accel_noise_radps2**2
        p = np.diag(variances)
        p[_POSE] = cov3
        p[TH, TH] = min(p[TH, TH], MAX_YAW_STD_RAD**2)
        self.initialize(stamp, state, p)

    def insert_logged(self, event: Event, now: float) -> Insert:
        """``insert``, logging a reset (a failed factorization), a rejection and an event
        too old to take."""
        counters = self.counters
        resets = counters.resets
        rejected = counters.rejected.get(event.source, 0)
        outcome = self.insert(event, now)
        if counters.resets > resets:
            # The filter reset itself from the last good state (a failed factorization).
            _log.warning(
                "ukf_reset", source=event.source, stamp=event.stamp, resets=counters.resets
            )
        if counters.rejected.get(event.source, 0) > rejected:
            _log.debug(
                "measurement_rejected",
                source=event.source,
                stamp=event.stamp,
                mahalanobis_sq=round(self.last_rejected_mahalanobis_sq, 2),
            )
        if outcome is Insert.TOO_OLD:
            _log.debug(
                "measurement_too_old", source=event.source, age_s=round(now - event.stamp, 3)
            )
        return outcome

    def pose_at(self, stamp: float) -> RobotPose:
        """The filter's pose at ``stamp`` (the state at or before it, predicted to it)."""
        then = self.at_or_before(stamp)
        f = transition_matrix(max(stamp - then.stamp, 0.0))
        x = f @ then.x
        cov = (f @ then.p @ f.T)[_POSE]
        return RobotPose(float(x[X]), float(x[Y]), wrap_angle(float(x[TH])), cov)

    def predict_to(self, x: FloatArray, stamp: float) -> FloatArray:
        """The state ``x`` (of the newest snapshot) predicted to ``stamp`` [s]."""
        dt = max(stamp - self.latest.stamp, 0.0)
        predicted: FloatArray = transition_matrix(dt) @ x
        return predicted
