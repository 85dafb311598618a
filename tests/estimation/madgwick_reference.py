"""An independent NumPy twin of the Madgwick kernel: quaternion algebra and a numeric gradient.

Nothing here is shared with navd's kernel. The error functions are those of Madgwick's
report (eqs. 25 and 29, which equal q* ⊗ d ⊗ q - measured on unit quaternions, checked by
``error_matches_rotation``); their gradient comes from central differences, so the kernel's
hand-expanded Jacobians are checked against the definition. Orientation outputs use
quaternion rotation.
"""

from __future__ import annotations

import math

import numpy as np

GRAVITY = 9.80665


def qmul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    w1, x1, y1, z1 = a
    w2, x2, y2, z2 = b
    return np.array(
        [
            w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
            w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
            w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
            w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2,
        ]
    )


def conj(q: np.ndarray) -> np.ndarray:
    return q * np.array([1.0, -1.0, -1.0, -1.0])


def to_earth(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    return qmul(qmul(q, np.r_[0.0, v]), conj(q))[1:]


def to_sensor(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    return qmul(qmul(conj(q), np.r_[0.0, v]), q)[1:]


def _predicted(q: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Gravity and field directions in the sensor frame, in the report's polynomial form."""
    q0, q1, q2, q3 = q
    bx, bz = b[0], b[2]
    return np.array(
        [
            2 * (q1 * q3 - q0 * q2),
            2 * (q0 * q1 + q2 * q3),
            2 * (0.5 - q1 * q1 - q2 * q2),
            2 * bx * (0.5 - q2 * q2 - q3 * q3) + 2 * bz * (q1 * q3 - q0 * q2),
            2 * bx * (q1 * q2 - q0 * q3) + 2 * bz * (q0 * q1 + q2 * q3),
            2 * bx * (q0 * q2 + q1 * q3) + 2 * bz * (0.5 - q1 * q1 - q2 * q2),
        ]
    )


def error_matches_rotation(q: np.ndarray, b: np.ndarray) -> bool:
    """True if the polynomial form equals the quaternion rotation for this unit ``q``."""
    by_rotation = np.r_[to_sensor(q, np.array([0.0, 0.0, 1.0])), to_sensor(q, b)]
    return bool(np.allclose(_predicted(q, b), by_rotation, atol=1e-12))


def _error(q: np.ndarray, acc: np.ndarray, mag: np.ndarray | None, b: np.ndarray) -> np.ndarray:
    predicted = _predicted(q, b)
    f = predicted[:3] - acc
    if mag is not None:
        f = np.r_[f, predicted[3:] - mag]
    return f


def gradient(q: np.ndarray, acc: np.ndarray, mag: np.ndarray | None) -> np.ndarray:
    b = np.zeros(3)
    if mag is not None:
        h = to_earth(q, mag)
        b = np.array([math.hypot(h[0], h[1]), 0.0, h[2]])
    f = _error(q, acc, mag, b)
    jac = np.empty((f.size, 4))
    eps = 1e-7
    for j in range(4):
        dq = np.zeros(4)
        dq[j] = eps
        jac[:, j] = (_error(q + dq, acc, mag, b) - _error(q - dq, acc, mag, b)) / (2 * eps)
    return jac.T @ f


def step(state: np.ndarray, params: np.ndarray, dt: float, sample: np.ndarray) -> np.ndarray:
    """One filter step on ``state`` (same layout as the kernel's first 9 slots); returns out."""
    beta, reject, bias_gain, still_gyro, still_time = params[:5]
    gyro, accel, mag_raw = sample[:3], sample[3:6], sample[6:9]
    has_mag = bool(np.any(mag_raw != 0.0))
    a_norm = float(np.linalg.norm(accel))
    if np.linalg.norm(gyro) < still_gyro and abs(a_norm - GRAVITY) < 0.5 * reject:
        state[7] += dt
    else:
        state[7] = 0.0
    if state[7] > still_time:
        state[4:7] += min(bias_gain * dt, 1.0) * (gyro - state[4:7])
    omega = gyro - state[4:7]
    q = state[:4].copy()
    q_dot = 0.5 * qmul(q, np.r_[0.0, omega])
    if a_norm > 0.0 and abs(a_norm - GRAVITY) <= reject:
        mag = mag_raw / np.linalg.norm(mag_raw) if has_mag else None
        if mag is not None:
            h = to_earth(q, mag)
            assert error_matches_rotation(q, np.array([math.hypot(h[0], h[1]), 0.0, h[2]]))
        g = gradient(q, accel / a_norm, mag)
        if np.linalg.norm(g) > 0.0:
            q_dot = q_dot - beta * g / np.linalg.norm(g)
    q = q + q_dot * dt
    q = q / np.linalg.norm(q)
    state[:4] = q
    e_acc = to_earth(q, accel)
    heading = to_earth(q, np.array([1.0, 0.0, 0.0]))
    yaw = math.atan2(heading[1], heading[0])
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array(
        [to_earth(q, omega)[2], c * e_acc[0] + s * e_acc[1], -s * e_acc[0] + c * e_acc[1], yaw]
    )
