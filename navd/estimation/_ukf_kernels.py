"""Numba kernels of the pose UKF: one step (predict, update, gate, with angles on the
circle), and the prediction by the linear model alone between events (``propagate``, the
published estimate).

The same algebra as the textbook UKF (Wan and van der Merwe 2000) as filterpy writes it, on
the 9-state model of ``motion_model`` with Merwe's scaled sigma points: predict propagates
the 2n + 1 points through the linear model and takes the unscented transform (yaw averaged
as wrapped offsets from the central point, see ``ukf.angle_mean``), then redraws the points
from the predicted mean and covariance; update passes them through the measurement rows and
applies the Kalman gain. The gate, the yaw variance cap and the symmetrization are those of
``ukf.PoseUkf``. One kernel call a step: in numpy the overhead of some sixty small array
calls was most of a step's cost (docs/estimation.md).

Measurement rows are given by code (``ROW_CODES`` in ``ukf``): 0 x, 1 y, 2 yaw (an angle),
3 yaw rate, 4 and 5 acceleration forward and left, 6 and 7 velocity forward and left (the
body frame is the state's yaw), 8 the range [m] and 9 the bearing [rad, an angle] from the
robot's centre to the row's landmark point (a beacon; ``points``, one x, y row per row).
Matrices are factored by Cholesky here (both the covariance for the sigma points and the
innovation covariance for the gain): a factor that fails, or anything not finite, reports
the step as diverged.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt
from numba import njit

from navd.geometry import wrap_angle_kernel as wrap

__all__ = ["APPLIED", "DIVERGED", "REJECTED", "propagate", "ukf_step"]

FloatArray = npt.NDArray[np.float64]

APPLIED = 0
REJECTED = 1  # predicted; the gated rows failed the gate (the tail rows applied)
DIVERGED = 2

_N = 9  # the state: x, y, vx, vy, ax, ay, yaw, yaw rate, yaw acceleration
_X, _Y, _VX, _VY, _AX, _AY, _TH, _VTH, _ATH = range(9)
_YAW_ROW = 2
_RANGE_ROW = 8
_BEARING_ROW = 9


@njit(cache=True, nogil=True)
def _product(a: FloatArray, b: FloatArray) -> FloatArray:
    """a @ b of two small matrices, in loops: numba's @ calls BLAS, whose code and call
    overhead cost more than the product on the filter's 9 x 9 matrices, most of all when the
    step runs cold between events (BLAS out of the caches)."""
    n, k = a.shape
    m = b.shape[1]
    out = np.zeros((n, m))
    for i in range(n):
        for j in range(k):
            v = a[i, j]
            for c in range(m):
                out[i, c] += v * b[j, c]
    return out


@njit(cache=True, nogil=True)
def _apply(a: FloatArray, v: FloatArray) -> FloatArray:
    """a @ v of a small matrix and a vector, in loops (see ``_product``)."""
    n, k = a.shape
    out = np.zeros(n)
    for i in range(n):
        s = 0.0
        for j in range(k):
            s += a[i, j] * v[j]
        out[i] = s
    return out


@njit(cache=True, nogil=True)
def _noise(dt: float, q_poly: FloatArray) -> FloatArray:
    """Q = [dt⁵, dt⁴, dt³, dt², dt] @ q_poly as the 9 x 9 process noise (in loops)."""
    q = np.zeros(_N * _N)
    power = dt
    for row in range(4, -1, -1):  # q_poly's rows: dt⁵ first, dt last
        for c in range(_N * _N):
            q[c] += power * q_poly[row, c]
        power *= dt
    return q.reshape(_N, _N)


@njit(cache=True, nogil=True)
def _cholesky(a: FloatArray) -> tuple[FloatArray, bool]:
    """Lower triangular L with L Lᵀ = a, and whether a was positive definite."""
    n = a.shape[0]
    low = np.zeros((n, n))
    for j in range(n):
        d = a[j, j]
        for k in range(j):
            d -= low[j, k] * low[j, k]
        if not d > 0.0:  # also catches NaN
            return low, False
        low[j, j] = math.sqrt(d)
        for i in range(j + 1, n):
            s = a[i, j]
            for k in range(j):
                s -= low[i, k] * low[j, k]
            low[i, j] = s / low[j, j]
    return low, True


@njit(cache=True, nogil=True)
def _solve(low: FloatArray, b: FloatArray) -> FloatArray:
    """x with (L Lᵀ) x = b, for each column of b (n x k)."""
    n, k = b.shape
    x = b.copy()
    for c in range(k):
        for i in range(n):  # L y = b
            s = x[i, c]
            for j in range(i):
                s -= low[i, j] * x[j, c]
            x[i, c] = s / low[i, i]
        for i in range(n - 1, -1, -1):  # Lᵀ x = y
            s = x[i, c]
            for j in range(i + 1, n):
                s -= low[j, i] * x[j, c]
            x[i, c] = s / low[i, i]
    return x


@njit(cache=True, nogil=True)
def _sigma_points(x: FloatArray, p: FloatArray, spread: float) -> tuple[FloatArray, bool]:
    """Merwe's points: x, then x plus and minus each row of U, UᵀU = spread · P (yaw
    wrapped)."""
    low, ok = _cholesky(spread * p)
    sigmas = np.empty((2 * _N + 1, _N))
    sigmas[0] = x
    for k in range(_N):
        for j in range(_N):
            u = low[j, k]  # row k of U = Lᵀ
            sigmas[1 + k, j] = x[j] + u
            sigmas[1 + _N + k, j] = x[j] - u
    for i in range(2 * _N + 1):
        sigmas[i, _TH] = wrap(sigmas[i, _TH])
    return sigmas, ok


@njit(cache=True, nogil=True)
def _angle_mean(values: FloatArray, weights: FloatArray) -> float:
    """Weighted mean of angles as wrapped offsets from the first (the central point's)."""
    reference = values[0]
    total = 0.0
    for i in range(values.shape[0]):
        total += weights[i] * wrap(values[i] - reference)
    return wrap(reference + total)


@njit(cache=True, nogil=True)
def _is_angle(code: int) -> bool:
    """True if row ``code`` is an angle (its residuals and means wrap on the circle)."""
    return code in (_YAW_ROW, _BEARING_ROW)


@njit(cache=True, nogil=True)
def _row_value(code: int, s: FloatArray, cos: float, sin: float, px: float, py: float) -> float:
    """Row ``code`` of state ``s`` (whose yaw has this cos and sin; (px, py) [m] is the
    row's landmark, for a range or a bearing)."""
    value: float
    if code == _RANGE_ROW:
        value = math.hypot(px - s[_X], py - s[_Y])
    elif code == _BEARING_ROW:
        value = wrap(math.atan2(py - s[_Y], px - s[_X]) - s[_TH])
    elif code == 0:
        value = s[_X]
    elif code == 1:
        value = s[_Y]
    elif code == _YAW_ROW:
        value = s[_TH]
    elif code == 3:
        value = s[_VTH]
    elif code == 4:
        value = cos * s[_AX] + sin * s[_AY]
    elif code == 5:
        value = -sin * s[_AX] + cos * s[_AY]
    elif code == 6:
        value = cos * s[_VX] + sin * s[_VY]
    else:
        value = -sin * s[_VX] + cos * s[_VY]
    return value


@njit(cache=True, nogil=True)
def _predict(
    x: FloatArray, p: FloatArray, dt: float, q_poly: FloatArray, wm: FloatArray,
    wc: FloatArray, spread: float,
) -> tuple[FloatArray, FloatArray, FloatArray, bool]:  # fmt: skip
    """The predicted mean, covariance and redrawn sigma points; False if a factor failed."""
    sigmas, ok = _sigma_points(x, p, spread)
    if not ok:
        return x, p, sigmas, False
    count = 2 * _N + 1
    moved = sigmas.copy()
    half = 0.5 * dt * dt
    for i in range(count):
        for pos, vel, acc in ((_X, _VX, _AX), (_Y, _VY, _AY), (_TH, _VTH, _ATH)):
            moved[i, pos] = sigmas[i, pos] + dt * sigmas[i, vel] + half * sigmas[i, acc]
            moved[i, vel] = sigmas[i, vel] + dt * sigmas[i, acc]
        moved[i, _TH] = wrap(moved[i, _TH])
    mean = np.zeros(_N)
    for i in range(count):
        for j in range(_N):
            mean[j] += wm[i] * moved[i, j]
    mean[_TH] = _angle_mean(moved[:, _TH], wm)
    cov = _noise(dt, q_poly)
    d = moved - mean
    for i in range(count):
        d[i, _TH] = wrap(d[i, _TH])
    for i in range(count):
        for a in range(_N):
            w = wc[i] * d[i, a]
            for b in range(_N):
                cov[a, b] += w * d[i, b]
    redrawn, ok = _sigma_points(mean, cov, spread)
    return mean, cov, redrawn, ok


@njit(cache=True, nogil=True)
def _update(
    x: FloatArray, p: FloatArray, sigmas: FloatArray, wm: FloatArray, wc: FloatArray,
    codes: npt.NDArray[np.int64], z: FloatArray, r: FloatArray, points: FloatArray,
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, bool]:  # fmt: skip
    """The updated mean and covariance, the residual y and its covariance S; False if S
    could not be factored."""
    count = 2 * _N + 1
    m = codes.shape[0]
    h = np.empty((count, m))
    for i in range(count):
        cos = math.cos(sigmas[i, _TH])
        sin = math.sin(sigmas[i, _TH])
        for j in range(m):
            h[i, j] = _row_value(codes[j], sigmas[i], cos, sin, points[j, 0], points[j, 1])
    z_mean = np.zeros(m)
    for i in range(count):
        for j in range(m):
            z_mean[j] += wm[i] * h[i, j]
    for j in range(m):
        if _is_angle(codes[j]):
            z_mean[j] = _angle_mean(h[:, j], wm)
    dz = h - z_mean
    dx = sigmas - x
    for i in range(count):
        dx[i, _TH] = wrap(dx[i, _TH])
        for j in range(m):
            if _is_angle(codes[j]):
                dz[i, j] = wrap(dz[i, j])
    s = r.copy()
    cross = np.zeros((_N, m))
    for i in range(count):
        for a in range(m):
            w = wc[i] * dz[i, a]
            for b in range(m):
                s[a, b] += w * dz[i, b]
            for b in range(_N):
                cross[b, a] += w * dx[i, b]
    y = z - z_mean
    for j in range(m):
        if _is_angle(codes[j]):
            y[j] = wrap(y[j])
    low, ok = _cholesky(s)
    if not ok:
        return x, p, y, s, False
    gain = _solve(low, cross.T).T  # K = Pxz S⁻¹ (S symmetric)
    new_x = x + _apply(gain, y)
    new_x[_TH] = wrap(new_x[_TH])
    new_p = p - _product(_product(gain, s), gain.T.copy())
    return new_x, new_p, y, s, True


@njit(cache=True, nogil=True)
def propagate(
    x: FloatArray, p: FloatArray, dt: float, q_poly: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """The mean and covariance ``dt`` [s] on by the linear model alone: F x and F P Fᵀ + Q
    (the estimate between events; no sigma points, the yaw left unwrapped). ``q_poly``: the
    5 x 81 process noise polynomial (``ProcessNoise.polynomial``)."""
    f = np.eye(_N)
    half = 0.5 * dt * dt
    for pos, vel, acc in ((_X, _VX, _AX), (_Y, _VY, _AY), (_TH, _VTH, _ATH)):
        f[pos, vel] = dt
        f[pos, acc] = half
        f[vel, acc] = dt
    return _apply(f, x), _product(_product(f, p), f.T.copy()) + _noise(dt, q_poly)


@njit(cache=True, nogil=True)
def ukf_step(
    x: FloatArray, p: FloatArray, dt: float, q_poly: FloatArray, wm: FloatArray,
    wc: FloatArray, spread: float, codes: npt.NDArray[np.int64], z: FloatArray,
    r: FloatArray, points: FloatArray, gated_rows: int, gate_chi2: float,
    max_yaw_var: float,
) -> tuple[int, FloatArray, FloatArray, float]:  # fmt: skip
    """Predict ``dt`` [s] ahead, then update with the rows ``codes`` (none: predict only).

    Args:
        x, p: the state mean and covariance (not changed).
        q_poly: process noise polynomial: Q = [dt⁵, dt⁴, dt³, dt², dt] @ q_poly, 5 x 81.
        wm, wc: the sigma points' mean and covariance weights; spread: λ + n.
        codes, z, r: the measurement rows, their values and noise covariance.
        points: [m] len(codes) x 2, the landmark of each range or bearing row (else unused).
        gated_rows: the first this many rows pass the Mahalanobis gate ``gate_chi2``; the
            rest ride along (applied alone when the gate refuses the others).
        max_yaw_var: [rad²] cap of the yaw variance (correlations scaled with it).

    Returns:
        (APPLIED, REJECTED or DIVERGED; new mean; new covariance; squared Mahalanobis
        distance of the gated rows, NaN if none).
    """
    mean, cov, sigmas, ok = _predict(x, p, dt, q_poly, wm, wc, spread)
    if not ok:
        return DIVERGED, x, p, math.nan
    outcome = APPLIED
    distance = math.nan
    m = codes.shape[0]
    if m > 0:
        new_x, new_p, y, s, ok = _update(mean, cov, sigmas, wm, wc, codes, z, r, points)
        if not ok:
            return DIVERGED, x, p, math.nan
        if gated_rows > 0:
            k = gated_rows
            low, ok = _cholesky(s[:k, :k].copy())
            if not ok:
                return DIVERGED, x, p, math.nan
            yk = y[:k].reshape(k, 1).copy()
            distance = _product(yk.T.copy(), _solve(low, yk))[0, 0]
            if not distance <= gate_chi2:
                outcome = REJECTED
                new_x, new_p = mean, cov
                if k < m:
                    tail_codes = codes[k:].copy()
                    tail_z = z[k:].copy()
                    tail_r = r[k:, k:].copy()
                    tail_points = points[k:].copy()
                    new_x, new_p, _, _, ok = _update(
                        mean, cov, sigmas, wm, wc, tail_codes, tail_z, tail_r, tail_points
                    )
                    if not ok:
                        return DIVERGED, x, p, distance
        mean, cov = new_x, new_p
    cov = 0.5 * (cov + cov.T)
    var = cov[_TH, _TH]
    if var > max_yaw_var:
        scale = math.sqrt(max_yaw_var / var)
        cov[_TH, :] *= scale
        cov[:, _TH] *= scale
    if not (np.all(np.isfinite(mean)) and np.all(np.isfinite(cov))):
        return DIVERGED, x, p, distance
    return outcome, mean, cov, distance
