"""The pose UKF: Merwe scaled sigma points over the 9-state model, angles on the circle.

Each step is one call into a numba kernel (``_ukf_kernels``): predict, update, the
Mahalanobis gate on the sensor's own rows, the yaw variance cap. The algebra is the textbook
UKF (Wan and van der Merwe 2000) as filterpy writes it; a test runs filterpy's own
UnscentedKalmanFilter on the same model (``navd.bench.ukf_reference``) and checks every step
against this one. filterpy is not imported by the daemon (docs/estimation.md says what it
would cost). Yaw residuals are wrapped, yaw means are taken on the circle, and the filter
never raises: a failed Cholesky factorization or a non-finite result is reported as
``StepOutcome.DIVERGED`` for the caller to reset from a good state.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import Enum

import numpy as np
import numpy.typing as npt

from navd.config import EstimationConfig
from navd.estimation._ukf_kernels import DIVERGED, REJECTED, ukf_step
from navd.estimation.motion_model import STATE_SIZE, ProcessNoise, Row

__all__ = ["MAX_YAW_STD_RAD", "ROW_CODES", "Measurement", "PoseUkf", "StepOutcome", "UkfSettings"]

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
        points: [m] len(rows) x 2, the landmark (a beacon's map point) of each RANGE or
            BEARING row; None when there are none.
    """

    rows: tuple[Row, ...]
    z: FloatArray
    r: FloatArray
    gated_rows: int
    points: FloatArray | None = None

    def __post_init__(self) -> None:
        m = len(self.rows)
        if not 0 <= self.gated_rows <= m:
            raise ValueError(f"gated_rows must be in 0..{m}, got {self.gated_rows}")
        if self.z.shape != (m,) or self.r.shape != (m, m):
            raise ValueError(
                f"z must be ({m},) and r ({m}, {m}); got {self.z.shape} and {self.r.shape}"
            )
        if self.points is not None and self.points.shape != (m, 2):
            raise ValueError(f"points must be ({m}, 2), got {self.points.shape}")
        if self.points is None and any(r in (Row.RANGE, Row.BEARING) for r in self.rows):
            raise ValueError("range and bearing rows need their landmarks' points")

    @property
    def landmarks(self) -> FloatArray:
        """[m] the rows' landmark points as the kernel takes them (zeros where unused)."""
        if self.points is not None:
            return np.ascontiguousarray(self.points, dtype=np.float64)
        return np.zeros((len(self.rows), 2))

    @property
    def codes(self) -> npt.NDArray[np.int64]:
        """The rows as the kernel's codes (``ROW_CODES``)."""
        codes = _CODES.get(self.rows)
        if codes is None:
            codes = _CODES[self.rows] = np.array([ROW_CODES[r] for r in self.rows], np.int64)
        return codes

    def tail(self) -> Measurement | None:
        """Only the rows that ride along, or None if there are none."""
        k = self.gated_rows
        if k == len(self.rows):
            return None
        points = None if self.points is None else self.points[k:]
        return Measurement(
            rows=self.rows[k:], z=self.z[k:], r=self.r[k:, k:], gated_rows=0, points=points
        )


# The measurement rows as ``_ukf_kernels`` knows them.
ROW_CODES = {
    Row.X: 0,
    Row.Y: 1,
    Row.YAW: 2,
    Row.YAW_RATE: 3,
    Row.ACCEL_FORWARD: 4,
    Row.ACCEL_LEFT: 5,
    Row.VELOCITY_FORWARD: 6,
    Row.VELOCITY_LEFT: 7,
    Row.RANGE: 8,
    Row.BEARING: 9,
}
_CODES: dict[tuple[Row, ...], npt.NDArray[np.int64]] = {}


class StepOutcome(Enum):
    """What a filter step did."""

    APPLIED = "applied"
    REJECTED = "rejected"  # predicted; the gated rows failed the gate (tail rows applied)
    DIVERGED = "diverged"  # numerically broken; the state must be reset


# Beyond this the yaw is as good as unknown (a uniform angle has std pi/sqrt(3)); letting it
# grow further would spread sigma points around the circle and break the circular mean.
MAX_YAW_STD_RAD = math.pi / math.sqrt(3.0)


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
        self._spread = alpha**2 * (n + kappa)  # lambda + n
        self._wm = np.full(2 * n + 1, 0.5 / self._spread)
        self._wc = self._wm.copy()
        self._wm[0] = (self._spread - n) / self._spread
        self._wc[0] = self._wm[0] + (1.0 - alpha**2 + beta)
        noise = ProcessNoise(settings.linear_jerk_psd, settings.angular_jerk_psd)
        self._q_poly = noise.polynomial
        self._x = np.zeros(n)
        self._p = np.eye(n)
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
        if measurement is None:
            codes, z, r, points, gated = _NO_ROWS, _NO_VALUES, _NO_NOISE, _NO_POINTS, 0
        else:
            codes, z, r, points, gated = (
                measurement.codes,
                measurement.z,
                measurement.r,
                measurement.landmarks,
                measurement.gated_rows,
            )
        outcome, x, p, distance = ukf_step(
            self._x,
            self._p,
            float(dt_s),
            self._q_poly,
            self._wm,
            self._wc,
            self._spread,
            codes,
            np.asarray(z, dtype=np.float64),
            np.asarray(r, dtype=np.float64),
            points,
            gated,
            float(gate_chi2),
            MAX_YAW_STD_RAD**2,
        )
        if gated:
            self.last_mahalanobis_sq = distance  # NaN when it could not be computed
        if outcome == DIVERGED:
            return StepOutcome.DIVERGED
        self._x, self._p = x, p
        return StepOutcome.REJECTED if outcome == REJECTED else StepOutcome.APPLIED


_NO_ROWS = np.zeros(0, dtype=np.int64)
_NO_VALUES = np.zeros(0)
_NO_NOISE = np.zeros((0, 0))
_NO_POINTS = np.zeros((0, 2))
