"""The pose UKF: Merwe scaled sigma points over the 9-state model, angles on the circle.

The algebra is the textbook UKF (Wan and van der Merwe 2000) as filterpy writes it, done
with array operations over all sigma points at once: predict propagates the points through
the linear model and takes the unscented transform, then redraws the points from the
predicted mean and covariance; update passes them through the measurement rows and applies
the Kalman gain. filterpy itself is not imported: its package loads scipy.stats and
scipy.optimize for likelihood helpers (38 MB of the daemon's memory, 0.3 s here and about a
second on the board), and its per-sigma-point loops were already replaced here. A test
checks this filter against filterpy's own UnscentedKalmanFilter, step for step. Yaw
residuals are wrapped, yaw means are taken on the circle (``angle_mean``), and the filter
never raises: a failed Cholesky factorization or a non-finite result is reported as
``StepOutcome.DIVERGED`` for the caller to reset from a good state.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import Enum
from typing import Any

import numpy as np
import numpy.typing as npt

from navd.config import EstimationConfig, NavdConfig
from navd.estimation.motion_model import (
    STATE_SIZE,
    TH,
    ProcessNoise,
    Row,
    evaluate_rows,
    transition_matrix,
)
from navd.geometry.angles import wrap_angle, wrap_angles

__all__ = ["MAX_YAW_STD_RAD", "Measurement", "PoseUkf", "StepOutcome", "UkfSettings", "angle_mean"]

FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True, slots=True, kw_only=True)
class Measurement:
    """One update: measured rows, their values and noise.

    Attributes:
        rows: what each element of ``z`` measures.
        z: measured values (angles in rad).
        r: measurement noise covariance (len(rows) square).
        gated_rows: the first this many rows are the sensor's own and pass the Mahalanobis
            gate; the rest (IMU, motion constraints) ride along.
    """

    rows: tuple[Row, ...]
    z: FloatArray
    r: FloatArray
    gated_rows: int

    def __post_init__(self) -> None:
        m = len(self.rows)
        if self.z.shape != (m,) or self.r.shape != (m, m):
            raise ValueError(
                f"z must be ({m},) and r ({m}, {m}); got {self.z.shape} and {self.r.shape}"
            )

    def tail(self) -> Measurement | None:
        """Only the rows that ride along, or None if there are none."""
        k = self.gated_rows
        if k == len(self.rows):
            return None
        return Measurement(rows=self.rows[k:], z=self.z[k:], r=self.r[k:, k:], gated_rows=0)


class StepOutcome(Enum):
    """What a filter step did."""

    APPLIED = "applied"
    REJECTED = "rejected"  # predicted; the gated rows failed the gate (tail rows applied)
    DIVERGED = "diverged"  # numerically broken; the state must be reset


def _upper_cholesky(matrix: FloatArray) -> FloatArray:
    """Upper triangular U with UᵀU = matrix (LinAlgError if not positive definite)."""
    upper = np.asarray(np.linalg.cholesky(matrix).T, dtype=np.float64)
    return upper


def _state_residual(a: FloatArray, b: FloatArray) -> FloatArray:
    d = a - b
    if d.ndim == 1:
        d[TH] = wrap_angle(float(d[TH]))
    else:
        d[:, TH] = wrap_angles(d[:, TH])
    return d


def _state_add(x: FloatArray, dx: FloatArray) -> FloatArray:
    s = x + dx
    s[TH] = wrap_angle(float(s[TH]))
    return s


def angle_mean(angles: FloatArray, weights: FloatArray) -> float:
    """Weighted mean of angles whose first element is the central sigma point.

    Averaged as wrapped offsets from the central point, so it stays right with the negative
    central weight of Merwe points: a sin/cos mean (atan2 of the weighted sines and cosines)
    flips by pi once the yaw spread makes the weighted cosine sum negative, which happens at
    yaw std near 1.4 rad with the seed's alpha = 0.1, kappa = 6. For small spreads the two
    agree to first order.
    """
    reference = float(angles[0])
    return wrap_angle(reference + float(weights @ wrap_angles(angles - reference)))


def _state_mean(sigmas: FloatArray, weights: FloatArray) -> FloatArray:
    mean = weights @ sigmas
    mean[TH] = angle_mean(sigmas[:, TH], weights)
    return mean


def _transform(  # noqa: PLR0917 - filterpy calls UT positionally
    sigmas: FloatArray,
    wm: FloatArray,
    wc: FloatArray,
    noise: FloatArray,
    mean_fn: Any,
    residual_fn: Any,
) -> tuple[FloatArray, FloatArray]:
    """Unscented transform over all sigma rows at once (filterpy's UT signature)."""
    mean: FloatArray = mean_fn(sigmas, wm)
    y: FloatArray = residual_fn(sigmas, mean)
    cov: FloatArray = (y * wc[:, None]).T @ y + noise
    return mean, cov


class _MeasurementFunctions:
    """Mean and residual of a measurement whose rows may include angles."""

    def __init__(self, rows: tuple[Row, ...]) -> None:
        self.angles = [i for i, row in enumerate(rows) if row.is_angle]

    def mean(self, sigmas: FloatArray, weights: FloatArray) -> FloatArray:
        mean = weights @ sigmas
        for i in self.angles:
            mean[i] = angle_mean(sigmas[:, i], weights)
        return mean

    def residual(self, a: FloatArray, b: FloatArray) -> FloatArray:
        d = a - b
        for i in self.angles:
            if d.ndim == 1:
                d[i] = wrap_angle(float(d[i]))
            else:
                d[:, i] = wrap_angles(d[:, i])
        return d


_FUNCTIONS: dict[tuple[Row, ...], _MeasurementFunctions] = {}


# Beyond this the yaw is as good as unknown (a uniform angle has std pi/sqrt(3)); letting it
# grow further would spread sigma points around the circle and break the circular mean.
MAX_YAW_STD_RAD = math.pi / math.sqrt(3.0)


def _bounded_yaw(p: FloatArray) -> FloatArray:
    """``p`` with the yaw variance capped, its correlations kept."""
    var = p[TH, TH]
    limit = MAX_YAW_STD_RAD**2
    if var > limit:
        scale = math.sqrt(limit / var)
        p[TH, :] *= scale
        p[:, TH] *= scale
    return p


@dataclass(frozen=True, slots=True)
class UkfSettings:
    """The filter's sigma points and process noise.

    Attributes:
        alpha, beta, kappa: Merwe sigma point parameters.
        linear_jerk_psd: [m²/s⁵] process noise of x and y.
        angular_jerk_psd: [rad²/s⁵] process noise of yaw.
    """

    alpha: float
    beta: float
    kappa: float
    linear_jerk_psd: float
    angular_jerk_psd: float

    @classmethod
    def from_config(cls, config: NavdConfig) -> UkfSettings:
        """The settings the estimation section describes."""
        return cls.of(config.estimation)

    @classmethod
    def of(cls, est: EstimationConfig) -> UkfSettings:
        """The settings of an estimation section."""
        return cls(
            alpha=est.ukf_alpha,
            beta=est.ukf_beta,
            kappa=est.ukf_kappa,
            linear_jerk_psd=est.accel_noise_mps2**2,
            angular_jerk_psd=est.angular_accel_noise_radps2**2,
        )


class PoseUkf:
    """UKF over the 9-state constant-acceleration model.

    Args:
        settings: sigma points and process noise (fixed for the instance: the state lives in
            the event history, so new settings take a new PoseUkf).
    """

    def __init__(self, settings: UkfSettings) -> None:
        self.settings = settings
        n = STATE_SIZE
        alpha, beta, kappa = settings.alpha, settings.beta, settings.kappa
        spread = alpha**2 * (n + kappa)  # lambda + n
        self._spread = spread
        self._wm = np.full(2 * n + 1, 0.5 / spread)
        self._wc = self._wm.copy()
        self._wm[0] = (spread - n) / spread
        self._wc[0] = (spread - n) / spread + (1.0 - alpha**2 + beta)
        self._process_noise = ProcessNoise(settings.linear_jerk_psd, settings.angular_jerk_psd)
        self._x = np.zeros(n)
        self._p = np.eye(n)
        self._sigmas = np.zeros((2 * n + 1, n))  # redrawn from the prediction
        self._y = np.zeros(0)  # the last update's residual and its covariance
        self._s = np.zeros((0, 0))
        self.last_mahalanobis_sq = math.nan

    @property
    def x(self) -> FloatArray:
        """The state mean (a copy)."""
        return self._x.copy()

    @property
    def p(self) -> FloatArray:
        """The state covariance (a copy)."""
        return self._p.copy()

    def set_state(self, x: FloatArray, p: FloatArray) -> None:
        """Replace mean and covariance (copies are kept)."""
        self._x = np.array(x, dtype=np.float64)
        self._p = np.array(p, dtype=np.float64)

    def step(self, dt_s: float, measurement: Measurement | None, gate_chi2: float) -> StepOutcome:
        """Predict ``dt_s`` [s] ahead, then update with ``measurement`` if given.

        The gated rows are applied only if their squared Mahalanobis distance is within
        ``gate_chi2``; otherwise the update is undone and only the tail rows are applied.
        """
        try:
            self._predict(dt_s)
            outcome = StepOutcome.APPLIED
            if measurement is not None:
                x_prior, p_prior = self._x, self._p
                self._update(measurement)
                if measurement.gated_rows and not self._passes_gate(measurement, gate_chi2):
                    self._x, self._p = x_prior, p_prior
                    outcome = StepOutcome.REJECTED
                    tail = measurement.tail()
                    if tail is not None:
                        self._update(tail)
            self._p = _bounded_yaw(0.5 * (self._p + self._p.T))
        except (np.linalg.LinAlgError, ValueError, FloatingPointError):
            return StepOutcome.DIVERGED
        if not (np.all(np.isfinite(self._x)) and np.all(np.isfinite(self._p))):
            return StepOutcome.DIVERGED
        return outcome

    def _sigma_points(self, x: FloatArray, p: FloatArray) -> FloatArray:
        """Merwe's points: x, then x plus and minus each row of U with UᵀU = (λ + n)P (yaw
        wrapped). Raises LinAlgError when P is not positive definite."""
        n = STATE_SIZE
        u = _upper_cholesky(self._spread * p)
        sigmas = np.empty((2 * n + 1, n))
        sigmas[0] = x
        sigmas[1 : n + 1] = x + u
        sigmas[n + 1 :] = x - u
        sigmas[:, TH] = wrap_angles(sigmas[:, TH])
        return sigmas

    def _predict(self, dt_s: float) -> None:
        propagated = self._sigma_points(self._x, self._p) @ transition_matrix(dt_s).T
        propagated[:, TH] = wrap_angles(propagated[:, TH])
        noise = self._process_noise(dt_s)
        self._x, self._p = _transform(
            propagated, self._wm, self._wc, noise, _state_mean, _state_residual
        )
        self._sigmas = self._sigma_points(self._x, self._p)

    def _update(self, measurement: Measurement) -> None:
        functions = _FUNCTIONS.get(measurement.rows)
        if functions is None:
            functions = _FUNCTIONS[measurement.rows] = _MeasurementFunctions(measurement.rows)
        sigmas_h = evaluate_rows(measurement.rows, self._sigmas)
        z_mean, s = _transform(
            sigmas_h, self._wm, self._wc, measurement.r, functions.mean, functions.residual
        )
        dx = _state_residual(self._sigmas, self._x)
        dz = functions.residual(sigmas_h, z_mean)
        cross = (dx * self._wc[:, None]).T @ dz
        gain = cross @ np.linalg.inv(s)
        self._y = functions.residual(measurement.z, z_mean)
        self._s = s
        self._x = _state_add(self._x, gain @ self._y)
        self._p = self._p - gain @ s @ gain.T

    def _passes_gate(self, measurement: Measurement, gate_chi2: float) -> bool:
        k = measurement.gated_rows
        y = self._y[:k]
        s = self._s[:k, :k]
        self.last_mahalanobis_sq = float(y @ np.linalg.solve(s, y))
        return self.last_mahalanobis_sq <= gate_chi2
