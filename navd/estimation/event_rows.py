"""What every position event carries beside its sensor's own rows: the IMU's mean yaw rate
and accelerations over the window before it, and, for a differential drive, the constraint
that the robot does not slide sideways (zero velocity to its left)."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from navd.config import EstimationConfig
from navd.estimation.motion_model import Row
from navd.estimation.ukf import Measurement

__all__ = ["IMU_ROWS", "event_measurement"]

FloatArray = npt.NDArray[np.float64]
IMU_ROWS = (Row.YAW_RATE, Row.ACCEL_FORWARD, Row.ACCEL_LEFT)


def event_measurement(
    rows: tuple[Row, ...],
    z: list[float],
    r: FloatArray,
    window: tuple[float, ...] | None,
    est: EstimationConfig,
    *,
    points: list[tuple[float, float]] | None = None,
) -> Measurement:
    """The sensor's ``rows`` (values ``z``, covariance ``r``) followed by the IMU ``window``'s
    mean (yaw rate, forward and left acceleration; None: no IMU) and the no-sliding row
    (``points`` [m]: the landmark of each of the sensor's rows, for ranges and bearings)."""
    tail_rows: tuple[Row, ...] = ()
    tail_values: tuple[float, ...] = ()
    tail_variances: tuple[float, ...] = ()
    if window is not None:
        # The configured noise is that of the window mean (vibration and bias included).
        accel_var = est.imu_accel_std_mps2**2
        tail_rows = IMU_ROWS
        tail_values = tuple(window[:3])
        tail_variances = (est.imu_yaw_rate_std_radps**2, accel_var, accel_var)
    if est.nonholonomic_std_mps is not None:
        tail_rows += (Row.VELOCITY_LEFT,)
        tail_values += (0.0,)
        tail_variances += (est.nonholonomic_std_mps**2,)
    k = len(rows)
    size = k + len(tail_rows)
    full = np.zeros((size, size))
    full[:k, :k] = r
    full[range(k, size), range(k, size)] = tail_variances
    landmarks = None
    if points is not None:
        landmarks = np.zeros((size, 2))
        landmarks[:k] = points
    return Measurement(
        rows=rows + tail_rows,
        z=np.array([*z, *tail_values]),
        r=full,
        gated_rows=k,
        points=landmarks,
    )
