"""The pose UKF: filterpy's UnscentedKalmanFilter with Merwe sigma points, angles on the circle.

filterpy does the predict/update algebra. Three of its per-sigma-point Python loops
(propagating sigma points, the unscented transform with custom residuals, the cross
covariance) are replaced by array operations, which makes a step several times cheaper
without changing a number. Yaw residuals are wrapped, yaw means are taken on the circle
(``angle_mean``), and the filter never raises: a failed Cholesky factorization or a
non-finite result is reported as ``StepOutcome.DIVERGED`` for the caller to reset from a
good state.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Iterator
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


@functools.cache
def _filter_classes() -> tuple[Any, Any]:
    """filterpy's UKF and Merwe points with the array versions of their loops.

    Imported on first use: filterpy's package pulls in scipy.stats (about a second), which
    the daemon should not pay before it is ready.
    """
    from filterpy.kalman import (  # noqa: PLC0415
        MerweScaledSigmaPoints,
        UnscentedKalmanFilter,
    )

    class _ArraySigmaPoints(MerweScaledSigmaPoints):  # type: ignore[misc]
        """filterpy's Merwe points, built without its per-dimension loop.

        Same points: with U the upper Cholesky factor of (λ + n)P, the points are x, x + U[k] and
        x - U[k] (yaw wrapped). The factorization raises LinAlgError when P is not positive
        definite.
        """

        def sigma_points(self, x: FloatArray, P: FloatArray) -> FloatArray:  # noqa: N803
            n = self.n
            u = self.sqrt((self._lambda() + n) * P)
            sigmas = np.empty((2 * n + 1, n))
            sigmas[0] = x
            sigmas[1 : n + 1] = x + u
            sigmas[n + 1 :] = x - u
            sigmas[:, TH] = wrap_angles(sigmas[:, TH])
            return sigmas

        def _lambda(self) -> float:
            return float(self.alpha**2 * (self.n + self.kappa) - self.n)

    class _ArrayUkf(UnscentedKalmanFilter):  # type: ignore[misc]
        """filterpy's UKF with its per-sigma-point loops done as array operations."""

        transition: FloatArray

        def compute_process_sigmas(self, dt: float, fx: Any = None, **fx_args: Any) -> None:
            sigmas = self.points_fn.sigma_points(self.x, self.P)
            propagated = sigmas @ self.transition.T
            propagated[:, TH] = wrap_angles(propagated[:, TH])
            self.sigmas_f = propagated

        def cross_variance(
            self, x: FloatArray, z: FloatArray, sigmas_f: FloatArray, sigmas_h: FloatArray
        ) -> FloatArray:
            dx = self.residual_x(sigmas_f, x)
            dz = self.residual_z(sigmas_h, z)
            result: FloatArray = (dx * self.Wc[:, None]).T @ dz
            return result

    return _ArraySigmaPoints, _ArrayUkf


def _unused_fx(x: FloatArray, dt: float) -> FloatArray:  # pragma: no cover - never called
    raise AssertionError("process sigmas are propagated by _ArrayUkf.compute_process_sigmas")


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
        alpha, beta, kappa = settings.alpha, settings.beta, settings.kappa
        linear_jerk_psd, angular_jerk_psd = settings.linear_jerk_psd, settings.angular_jerk_psd
        sigma_points_class, ukf_class = _filter_classes()
        points = sigma_points_class(
            STATE_SIZE,
            alpha=alpha,
            beta=beta,
            kappa=kappa,
            sqrt_method=_upper_cholesky,
            subtract=_state_residual,
        )
        self._ukf = ukf_class(
            dim_x=STATE_SIZE,
            dim_z=3,
            dt=0.0,
            hx=None,
            fx=_unused_fx,
            points=points,
            x_mean_fn=_state_mean,
            residual_x=_state_residual,
            state_add=_state_add,
        )
        self._ukf.transition = np.eye(STATE_SIZE)
        self._process_noise = ProcessNoise(linear_jerk_psd, angular_jerk_psd)
        self.last_mahalanobis_sq = math.nan

    @property
    def x(self) -> FloatArray:
        """The state mean (a copy)."""
        return np.array(self._ukf.x, dtype=np.float64)

    @property
    def p(self) -> FloatArray:
        """The state covariance (a copy)."""
        return np.array(self._ukf.P, dtype=np.float64)

    def set_state(self, x: FloatArray, p: FloatArray) -> None:
        """Replace mean and covariance (copies are kept)."""
        self._ukf.x = np.array(x, dtype=np.float64)
        self._ukf.P = np.array(p, dtype=np.float64)

    def step(self, dt_s: float, measurement: Measurement | None, gate_chi2: float) -> StepOutcome:
        """Predict ``dt_s`` [s] ahead, then update with ``measurement`` if given.

        The gated rows are applied only if their squared Mahalanobis distance is within
        ``gate_chi2``; otherwise the update is undone and only the tail rows are applied.
        """
        ukf = self._ukf
        try:
            ukf.transition = transition_matrix(dt_s)
            ukf.Q = self._process_noise(dt_s)
            ukf.predict(dt=dt_s, UT=_transform)
            outcome = StepOutcome.APPLIED
            if measurement is not None:
                self._update(measurement)
                if measurement.gated_rows and not self._passes_gate(measurement, gate_chi2):
                    ukf.x = ukf.x_prior.copy()
                    ukf.P = ukf.P_prior.copy()
                    outcome = StepOutcome.REJECTED
                    tail = measurement.tail()
                    if tail is not None:
                        self._update(tail)
            ukf.P = _bounded_yaw(0.5 * (ukf.P + ukf.P.T))
        except (np.linalg.LinAlgError, ValueError, FloatingPointError):
            return StepOutcome.DIVERGED
        if not (np.all(np.isfinite(ukf.x)) and np.all(np.isfinite(ukf.P))):
            return StepOutcome.DIVERGED
        return outcome

    def _update(self, measurement: Measurement) -> None:
        ukf = self._ukf
        functions = _FUNCTIONS.get(measurement.rows)
        if functions is None:
            functions = _FUNCTIONS[measurement.rows] = _MeasurementFunctions(measurement.rows)
        ukf.z_mean = functions.mean
        ukf.residual_z = functions.residual
        # All sigma points through the measurement rows at once; filterpy asks point by point.
        table = evaluate_rows(measurement.rows, ukf.sigmas_f)
        rows: Iterator[FloatArray] = iter(table)
        ukf.update(measurement.z, R=measurement.r, UT=_transform, hx=lambda _x: next(rows))

    def _passes_gate(self, measurement: Measurement, gate_chi2: float) -> bool:
        k = measurement.gated_rows
        y = self._ukf.y[:k]
        s = self._ukf.S[:k, :k]
        self.last_mahalanobis_sq = float(y @ np.linalg.solve(s, y))
        return self.last_mahalanobis_sq <= gate_chi2
