"""The pose UKF's model as numpy functions in filterpy's signatures (the mean, residual and
addition of states with yaw on the circle, the measurement rows' mean and residual, the
Cholesky factor), and filterpy's own UnscentedKalmanFilter set up to run it. The daemon's
filter is the kernel in ``_ukf_kernels``; this is what it is checked against (the tests) and
timed beside (``navd bench compare``). filterpy is a development dependency, imported only
by ``stock_filter``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from navd.estimation import STATE_SIZE, TH, Row, evaluate_rows, transition_matrix
from navd.geometry import wrap_angle, wrap_angles

__all__ = [
    "MeasurementFunctions",
    "angle_mean",
    "state_add",
    "state_mean",
    "state_residual",
    "stock_filter",
    "upper_cholesky",
]

if TYPE_CHECKING:
    from navd.estimation import UkfSettings

FloatArray = npt.NDArray[np.float64]


def upper_cholesky(matrix: FloatArray) -> FloatArray:
    """Upper triangular U with UᵀU = matrix (LinAlgError if not positive definite)."""
    upper = np.asarray(np.linalg.cholesky(matrix).T, dtype=np.float64)
    return upper


def state_residual(a: FloatArray, b: FloatArray) -> FloatArray:
    d = a - b
    if d.ndim == 1:
        d[TH] = wrap_angle(float(d[TH]))
    else:
        d[:, TH] = wrap_angles(d[:, TH])
    return d


def state_add(x: FloatArray, dx: FloatArray) -> FloatArray:
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


def state_mean(sigmas: FloatArray, weights: FloatArray) -> FloatArray:
    mean = weights @ sigmas
    mean[TH] = angle_mean(sigmas[:, TH], weights)
    return mean


class MeasurementFunctions:
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


def stock_filter(
    settings: UkfSettings, rows: tuple[Row, ...], landmarks: FloatArray | None = None
) -> Any:
    """filterpy's UnscentedKalmanFilter with Merwe points, running navd's model for a
    measurement of ``rows`` (``landmarks``: the points of its range and bearing rows), with
    its per-sigma-point loops as filterpy's documentation calls it: ``predict(dt=...)`` after
    setting ``Q``, then ``update(z, R=...)``."""
    from filterpy.kalman import (  # noqa: PLC0415 - a development dependency
        MerweScaledSigmaPoints,
        UnscentedKalmanFilter,
    )

    functions = MeasurementFunctions(rows)

    def fx(x: FloatArray, dt: float) -> FloatArray:
        moved: FloatArray = transition_matrix(dt) @ x
        moved[TH : TH + 1] = wrap_angles(moved[TH : TH + 1])
        return moved

    def hx(x: FloatArray) -> FloatArray:
        row: FloatArray = evaluate_rows(rows, x[None, :], landmarks)[0]
        return row

    points = MerweScaledSigmaPoints(
        STATE_SIZE,
        alpha=settings.alpha,
        beta=settings.beta,
        kappa=settings.kappa,
        sqrt_method=upper_cholesky,
        subtract=state_residual,
    )
    return UnscentedKalmanFilter(
        dim_x=STATE_SIZE,
        dim_z=len(rows),
        dt=0.1,
        hx=hx,
        fx=fx,
        points=points,
        x_mean_fn=state_mean,
        z_mean_fn=functions.mean,
        residual_x=state_residual,
        residual_z=functions.residual,
        state_add=state_add,
    )
