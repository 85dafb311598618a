"""The 9-state constant-acceleration model of seed eq. 3.1, and the measurement rows.

State X = (x, y, vx, vy, ax, ay, θ, vθ, aθ): position [m], velocity [m/s] and acceleration
[m/s²] in the map frame, yaw [rad] counter-clockwise from map +x, yaw rate [rad/s], yaw
acceleration [rad/s²]. Over a step Δt each of the three (position, velocity, acceleration)
chains moves as p += vΔt + ½aΔt², v += aΔt, with the acceleration a random walk driven by
continuous white jerk of spectral density q (so the process noise is right for any Δt).

Measurement rows are functions of the state evaluated on all sigma points at once (rows of
a matrix); rows that are angles are flagged so residuals wrap and means go through sin/cos.
"""

from __future__ import annotations

from enum import Enum
from typing import ClassVar

import numpy as np
import numpy.typing as npt

from navd.geometry import wrap_angles

__all__ = [
    "ATH",
    "AX",
    "AY",
    "STATE_SIZE",
    "TH",
    "VTH",
    "VX",
    "VY",
    "ProcessNoise",
    "Row",
    "X",
    "Y",
    "evaluate_rows",
    "transition_matrix",
]

FloatArray = npt.NDArray[np.float64]

X, Y, VX, VY, AX, AY, TH, VTH, ATH = range(9)
STATE_SIZE = 9
_CHAINS = ((X, VX, AX), (Y, VY, AY), (TH, VTH, ATH))


def transition_matrix(dt_s: float) -> FloatArray:
    """F of seed eq. 3.1 for a step of ``dt_s`` [s]."""
    f = np.eye(STATE_SIZE)
    for p, v, a in _CHAINS:
        f[p, v] = dt_s
        f[p, a] = 0.5 * dt_s * dt_s
        f[v, a] = dt_s
    return f


class ProcessNoise:
    """Q for any step under continuous white jerk, as a polynomial in the step length.

    Per (position, velocity, acceleration) chain with jerk spectral density q, Q is q times
    [[Δt⁵/20, Δt⁴/8, Δt³/6], [Δt⁴/8, Δt³/3, Δt²/2], [Δt³/6, Δt²/2, Δt]].

    Args:
        linear_jerk_psd: [m²/s⁵] spectral density of the x and y jerk.
        angular_jerk_psd: [rad²/s⁵] spectral density of the yaw jerk.
    """

    _BLOCK_BY_POWER: ClassVar[dict[int, tuple[tuple[int, int, float], ...]]] = {
        5: ((0, 0, 1 / 20),),
        4: ((0, 1, 1 / 8), (1, 0, 1 / 8)),
        3: ((0, 2, 1 / 6), (2, 0, 1 / 6), (1, 1, 1 / 3)),
        2: ((1, 2, 1 / 2), (2, 1, 1 / 2)),
        1: ((2, 2, 1.0),),
    }

    def __init__(self, linear_jerk_psd: float, angular_jerk_psd: float) -> None:
        psds = (linear_jerk_psd, linear_jerk_psd, angular_jerk_psd)
        coefficients = np.zeros((5, STATE_SIZE, STATE_SIZE))
        for power, entries in self._BLOCK_BY_POWER.items():
            for chain, psd in zip(_CHAINS, psds, strict=True):
                for i, j, factor in entries:
                    coefficients[5 - power, chain[i], chain[j]] = psd * factor
        self._coefficients = coefficients.reshape(5, STATE_SIZE * STATE_SIZE)

    @property
    def polynomial(self) -> FloatArray:
        """5 x 81: Q = [dt⁵, dt⁴, dt³, dt², dt] @ this, reshaped 9 x 9 (a copy)."""
        return self._coefficients.copy()

    def __call__(self, dt_s: float) -> FloatArray:
        """Q for a step of ``dt_s`` [s]."""
        t = dt_s
        powers = np.array([t**5, t**4, t**3, t**2, t])
        q: FloatArray = (powers @ self._coefficients).reshape(STATE_SIZE, STATE_SIZE)
        return q


class Row(Enum):
    """One measured quantity, as a function of the state (vectorized over sigma rows)."""

    X = "x"
    Y = "y"
    YAW = "yaw"
    YAW_RATE = "yaw_rate"
    ACCEL_FORWARD = "accel_forward"
    ACCEL_LEFT = "accel_left"
    VELOCITY_FORWARD = "velocity_forward"
    VELOCITY_LEFT = "velocity_left"
    # to a landmark at a known map point (a beacon): [m] the distance from the robot's
    # centre, and [rad] its bearing from the robot's forward axis
    RANGE = "range"
    BEARING = "bearing"

    @property
    def is_angle(self) -> bool:
        """True if residuals of this row wrap on the circle."""
        return self in (Row.YAW, Row.BEARING)


def evaluate_rows(
    rows: tuple[Row, ...], sigmas: FloatArray, points: FloatArray | None = None
) -> FloatArray:
    """All ``rows`` for every state row of ``sigmas`` (N x 9): an N x len(rows) table.
    ``points`` [m] (len(rows) x 2) gives the landmark of each RANGE or BEARING row."""
    table = np.empty((sigmas.shape[0], len(rows)))
    cos = sin = None
    for i, row in enumerate(rows):
        if row in (Row.RANGE, Row.BEARING):
            assert points is not None, "a range or bearing row needs its landmark's point"
            dx = points[i, 0] - sigmas[:, X]
            dy = points[i, 1] - sigmas[:, Y]
            if row is Row.RANGE:
                table[:, i] = np.hypot(dx, dy)
            else:
                table[:, i] = wrap_angles(np.arctan2(dy, dx) - sigmas[:, TH])
            continue
        source = _DIRECT_COLUMNS.get(row)
        if source is not None:
            table[:, i] = sigmas[:, source]
            continue
        if cos is None or sin is None:
            cos = np.cos(sigmas[:, TH])
            sin = np.sin(sigmas[:, TH])
        first, second, left = _HEADING_ROWS[row]
        if left:
            table[:, i] = -sin * sigmas[:, first] + cos * sigmas[:, second]
        else:
            table[:, i] = cos * sigmas[:, first] + sin * sigmas[:, second]
    return table


_DIRECT_COLUMNS = {Row.X: X, Row.Y: Y, Row.YAW: TH, Row.YAW_RATE: VTH}
_HEADING_ROWS = {
    Row.ACCEL_FORWARD: (AX, AY, False),
    Row.ACCEL_LEFT: (AX, AY, True),
    Row.VELOCITY_FORWARD: (VX, VY, False),
    Row.VELOCITY_LEFT: (VX, VY, True),
}
