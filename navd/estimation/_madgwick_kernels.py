"""Numba kernels of Madgwick's orientation filter (gyro + accelerometer [+ magnetometer]).

Quaternion q = (w, x, y, z) rotates the sensor frame into Madgwick's earth frame: z up,
x towards magnetic north when a magnetometer is used (otherwise the initial heading), so
y points west. One step, with ω the bias-corrected gyro, â the unit accelerometer and
m̂ the unit magnetometer reading:

    q̇ = ½ q ⊗ (0, ω) - β ∇f / |∇f|,    q ← normalize(q + q̇ Δt)

where ∇f = Jᵀ f is the gradient of the error between the measured directions and the
gravity (and magnetic field) directions predicted by q. The correction is skipped while
|‖a‖ - g| exceeds the rejection threshold (the robot is accelerating hard), and gyro bias is
learned by a slow low-pass while the sensor is still.

State layout (float64[STATE_SIZE]): q (4), gyro bias (3) [rad/s], seconds held still [s],
initialized flag, then for ``madgwick_ingest``: last stamp [s] (NaN before the first), ring
head, ring fill, samples out of order, gaps clamped. Params (float64[PARAM_SIZE]): β [rad/s],
accel rejection [m/s²], bias gain [1/s], stillness gyro threshold [rad/s], stillness time
before learning [s], longest step integrated [s].

The ring (float64[capacity, RING_COLUMNS]) keeps, per sample: stamp [s], levelled yaw rate
[rad/s], forward and left acceleration [m/s²], yaw [rad].
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np
import numpy.typing as npt

__all__ = [
    "GRAVITY_MPS2",
    "PARAM_SIZE",
    "RING_COLUMNS",
    "STATE_SIZE",
    "imu_window_mean",
    "madgwick_ingest",
    "madgwick_step",
]

GRAVITY_MPS2 = 9.80665
STATE_SIZE = 14
PARAM_SIZE = 6
OUT_SIZE = 4  # yaw rate [rad/s], forward and left acceleration [m/s²], yaw [rad]
RING_COLUMNS = 1 + OUT_SIZE
LAST_STAMP, RING_HEAD, RING_FILL, OUT_OF_ORDER, GAPS = range(9, 14)

FloatArray = npt.NDArray[np.float64]


@nb.njit(cache=True, nogil=True)
def _initialize(
    state: FloatArray, ax: float, ay: float, az: float, mx: float, my: float, mz: float
) -> None:
    """Set q from one accelerometer (and magnetometer) reading: roll, pitch, heading."""
    roll = math.atan2(ay, az)
    pitch = math.atan2(-ax, math.sqrt(ay * ay + az * az))
    yaw = 0.0
    if mx != 0.0 or my != 0.0 or mz != 0.0:
        # Tilt-compensate the magnetic vector; heading is the angle that brings it to +x.
        cr, sr = math.cos(roll), math.sin(roll)
        cp, sp = math.cos(pitch), math.sin(pitch)
        hx = mx * cp + my * sp * sr + mz * sp * cr
        hy = my * cr - mz * sr
        yaw = math.atan2(-hy, hx)
    cr, sr = math.cos(roll / 2), math.sin(roll / 2)
    cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    state[0] = cr * cp * cy + sr * sp * sy
    state[1] = sr * cp * cy - cr * sp * sy
    state[2] = cr * sp * cy + sr * cp * sy
    state[3] = cr * cp * sy - sr * sp * cy
    state[8] = 1.0


@nb.njit(cache=True, nogil=True)
def madgwick_step(
    state: FloatArray,
    params: FloatArray,
    out: FloatArray,
    dt: float,
    gx: float,
    gy: float,
    gz: float,
    ax: float,
    ay: float,
    az: float,
    mx: float,
    my: float,
    mz: float,
) -> None:
    """Advance ``state`` by one sample of duration ``dt`` [s] and write ``out``.

    Gyro in rad/s, accelerometer in m/s², magnetometer in any unit (all zero: none).
    ``out`` receives the levelled yaw rate [rad/s], the gravity-free acceleration along the
    heading and to its left [m/s²], and the yaw [rad] in the earth frame.
    """
    a_norm = math.sqrt(ax * ax + ay * ay + az * az)
    has_mag = mx != 0.0 or my != 0.0 or mz != 0.0
    if state[8] == 0.0 and a_norm > 0.0:
        _initialize(state, ax, ay, az, mx, my, mz)
    beta, reject, bias_gain, still_gyro, still_time = (
        params[0],
        params[1],
        params[2],
        params[3],
        params[4],
    )
    # Gyro bias: learn while the sensor has been still for a while.
    raw_rate = math.sqrt(gx * gx + gy * gy + gz * gz)
    if raw_rate < still_gyro and abs(a_norm - GRAVITY_MPS2) < 0.5 * reject:
        state[7] += dt
    else:
        state[7] = 0.0
    if state[7] > still_time:
        k = min(bias_gain * dt, 1.0)
        state[4] += k * (gx - state[4])
        state[5] += k * (gy - state[5])
        state[6] += k * (gz - state[6])
    wx = gx - state[4]
    wy = gy - state[5]
    wz = gz - state[6]
    q0, q1, q2, q3 = state[0], state[1], state[2], state[3]
    # Rate of change of q from the gyro alone.
    d0 = 0.5 * (-q1 * wx - q2 * wy - q3 * wz)
    d1 = 0.5 * (q0 * wx + q2 * wz - q3 * wy)
    d2 = 0.5 * (q0 * wy - q1 * wz + q3 * wx)
    d3 = 0.5 * (q0 * wz + q1 * wy - q2 * wx)
    if a_norm > 0.0 and abs(a_norm - GRAVITY_MPS2) <= reject:
        ux, uy, uz = ax / a_norm, ay / a_norm, az / a_norm
        # Gravity error f_g and its gradient J_gᵀ f_g.
        f1 = 2.0 * (q1 * q3 - q0 * q2) - ux
        f2 = 2.0 * (q0 * q1 + q2 * q3) - uy
        f3 = 2.0 * (0.5 - q1 * q1 - q2 * q2) - uz
        s0 = -2.0 * q2 * f1 + 2.0 * q1 * f2
        s1 = 2.0 * q3 * f1 + 2.0 * q0 * f2 - 4.0 * q1 * f3
        s2 = -2.0 * q0 * f1 + 2.0 * q3 * f2 - 4.0 * q2 * f3
        s3 = 2.0 * q1 * f1 + 2.0 * q2 * f2
        if has_mag:
            m_norm = math.sqrt(mx * mx + my * my + mz * mz)
            nx, ny, nz = mx / m_norm, my / m_norm, mz / m_norm
            # Earth field direction b = (bx, 0, bz) from the measurement seen through q.
            hx = (
                nx * (q0 * q0 + q1 * q1 - q2 * q2 - q3 * q3)
                + 2.0 * ny * (q1 * q2 - q0 * q3)
                + 2.0 * nz * (q1 * q3 + q0 * q2)
            )
            hy = (
                2.0 * nx * (q1 * q2 + q0 * q3)
                + ny * (q0 * q0 - q1 * q1 + q2 * q2 - q3 * q3)
                + 2.0 * nz * (q2 * q3 - q0 * q1)
            )
            hz = (
                2.0 * nx * (q1 * q3 - q0 * q2)
                + 2.0 * ny * (q2 * q3 + q0 * q1)
                + nz * (q0 * q0 - q1 * q1 - q2 * q2 + q3 * q3)
            )
            bx = math.sqrt(hx * hx + hy * hy)
            bz = hz
            # Magnetic error f_b and its gradient J_bᵀ f_b.
            g1 = 2.0 * bx * (0.5 - q2 * q2 - q3 * q3) + 2.0 * bz * (q1 * q3 - q0 * q2) - nx
            g2 = 2.0 * bx * (q1 * q2 - q0 * q3) + 2.0 * bz * (q0 * q1 + q2 * q3) - ny
            g3 = 2.0 * bx * (q0 * q2 + q1 * q3) + 2.0 * bz * (0.5 - q1 * q1 - q2 * q2) - nz
            s0 += -2.0 * bz * q2 * g1 + (-2.0 * bx * q3 + 2.0 * bz * q1) * g2 + 2.0 * bx * q2 * g3
            s1 += (
                2.0 * bz * q3 * g1
                + (2.0 * bx * q2 + 2.0 * bz * q0) * g2
                + (2.0 * bx * q3 - 4.0 * bz * q1) * g3
            )
            s2 += (
                (-4.0 * bx * q2 - 2.0 * bz * q0) * g1
                + (2.0 * bx * q1 + 2.0 * bz * q3) * g2
                + (2.0 * bx * q0 - 4.0 * bz * q2) * g3
            )
            s3 += (
                (-4.0 * bx * q3 + 2.0 * bz * q1) * g1
                + (-2.0 * bx * q0 + 2.0 * bz * q2) * g2
                + 2.0 * bx * q1 * g3
            )
        s_norm = math.sqrt(s0 * s0 + s1 * s1 + s2 * s2 + s3 * s3)
        if s_norm > 0.0:
            d0 -= beta * s0 / s_norm
            d1 -= beta * s1 / s_norm
            d2 -= beta * s2 / s_norm
            d3 -= beta * s3 / s_norm
    q0 += d0 * dt
    q1 += d1 * dt
    q2 += d2 * dt
    q3 += d3 * dt
    q_norm = math.sqrt(q0 * q0 + q1 * q1 + q2 * q2 + q3 * q3)
    q0, q1, q2, q3 = q0 / q_norm, q1 / q_norm, q2 / q_norm, q3 / q_norm
    state[0], state[1], state[2], state[3] = q0, q1, q2, q3
    # Rotation matrix rows of q (sensor -> earth) for the levelled outputs.
    r20 = 2.0 * (q1 * q3 - q0 * q2)
    r21 = 2.0 * (q2 * q3 + q0 * q1)
    r22 = 1.0 - 2.0 * (q1 * q1 + q2 * q2)
    r00 = 1.0 - 2.0 * (q2 * q2 + q3 * q3)
    r01 = 2.0 * (q1 * q2 - q0 * q3)
    r02 = 2.0 * (q1 * q3 + q0 * q2)
    r10 = 2.0 * (q1 * q2 + q0 * q3)
    r11 = 1.0 - 2.0 * (q1 * q1 + q3 * q3)
    r12 = 2.0 * (q2 * q3 - q0 * q1)
    yaw = math.atan2(r10, r00)
    # Earth-frame acceleration without gravity, then turned into the heading frame.
    e_ax = r00 * ax + r01 * ay + r02 * az
    e_ay = r10 * ax + r11 * ay + r12 * az
    cy, sy = math.cos(yaw), math.sin(yaw)
    out[0] = r20 * wx + r21 * wy + r22 * wz
    out[1] = cy * e_ax + sy * e_ay
    out[2] = -sy * e_ax + cy * e_ay
    out[3] = yaw


@nb.njit(cache=True, nogil=True)
def madgwick_ingest(
    state: FloatArray,
    ring: FloatArray,
    stamp: float,
    gx: float,
    gy: float,
    gz: float,
    ax: float,
    ay: float,
    az: float,
    mx: float,
    my: float,
    mz: float,
) -> bool:
    """Take one sample stamped ``stamp`` [s]: step the filter and append to ``ring``.

    ``state`` here holds the params after its STATE_SIZE slots (one array: a call per IMU
    sample costs mostly argument checks, and each array argument adds to them).

    The step length is the time since the previous sample. A sample not newer than the
    previous one is counted and skipped; a gap longer than the last param is counted and
    integrated as that. The first sample only sets the orientation.

    Returns:
        True if the sample was used.
    """
    params = state[STATE_SIZE:]
    last = state[LAST_STAMP]
    if math.isnan(last):
        dt = 0.0
    else:
        dt = stamp - last
        if dt <= 0.0:
            state[OUT_OF_ORDER] += 1.0
            return False
        if dt > params[5]:
            state[GAPS] += 1.0
            dt = params[5]
    state[LAST_STAMP] = stamp
    capacity = ring.shape[0]
    head = int(state[RING_HEAD])
    row = ring[head]
    madgwick_step(state, params, row[1:], dt, gx, gy, gz, ax, ay, az, mx, my, mz)
    row[0] = stamp
    state[RING_HEAD] = (head + 1) % capacity
    state[RING_FILL] = min(state[RING_FILL] + 1.0, capacity)
    return True


@nb.njit(cache=True, nogil=True)
def imu_window_mean(
    ring: FloatArray, head: int, fill: int, start_s: float, end_s: float, out: FloatArray
) -> int:
    """Mean yaw rate, forward and left acceleration of ring samples stamped in (start, end].

    Scans back from the newest sample. ``out`` (3) receives the means.

    Returns:
        The number of samples averaged (0 leaves ``out`` untouched).
    """
    capacity = ring.shape[0]
    total_rate = 0.0
    total_fwd = 0.0
    total_left = 0.0
    n = 0
    for k in range(fill):
        row = ring[(head - 1 - k) % capacity]
        if row[0] <= start_s:
            break
        if row[0] <= end_s:
            total_rate += row[1]
            total_fwd += row[2]
            total_left += row[3]
            n += 1
    if n > 0:
        out[0] = total_rate / n
        out[1] = total_fwd / n
        out[2] = total_left / n
    return n
