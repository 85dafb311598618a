"""Madgwick IMU orientation: the stateful face of the kernels in ``_madgwick_kernels``.

Fed every IMU sample (up to 1 kHz), it keeps the orientation, the learned gyro bias, and a
ring of per-sample levelled yaw rates and accelerations from which position events take
their IMU rows (``window_mean``). The IMU is assumed mounted with its axes along
base_link's (x forward, y left, z up).
"""

from __future__ import annotations

import math
from dataclasses import astuple, dataclass
from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from navd.config import EstimationConfig
from navd.estimation import _madgwick_kernels as k
from navd.lifecycle.messages import Imu, Vector3

__all__ = ["GRAVITY_MPS2", "ImuWindow", "MadgwickFilter", "MadgwickSettings"]

GRAVITY_MPS2 = k.GRAVITY_MPS2

FloatArray = npt.NDArray[np.float64]
_NO_MAG = Vector3(0.0, 0.0, 0.0)
_RING_RATE_HZ = 1000.0


class ImuWindow(NamedTuple):
    """IMU means over a window before an event, in the heading-aligned level frame.

    Attributes:
        yaw_rate_radps: [rad/s] rotation about the vertical, counter-clockwise positive.
        accel_forward_mps2: [m/s²] gravity-free acceleration along the heading.
        accel_left_mps2: [m/s²] gravity-free acceleration to the left of the heading.
        samples: how many IMU samples were averaged.
    """

    yaw_rate_radps: float
    accel_forward_mps2: float
    accel_left_mps2: float
    samples: int


@dataclass(frozen=True, slots=True)
class MadgwickSettings:
    """The filter's gains, in the order the kernels take them (``PARAM_SIZE`` values).

    Attributes:
        beta_radps: [rad/s] Madgwick gain.
        accel_reject_mps2: [m/s^2] skip the accelerometer while |accel| is off g by more.
        bias_gain_per_s: [1/s] how fast gyro bias is learned while still.
        still_gyro_radps: [rad/s] below this the IMU may be still.
        still_time_s: [s] stillness needed before bias is learned.
        max_gap_s: [s] longer gaps between samples are integrated as this.
    """

    beta_radps: float
    accel_reject_mps2: float
    bias_gain_per_s: float
    still_gyro_radps: float
    still_time_s: float
    max_gap_s: float

    @classmethod
    def of(cls, est: EstimationConfig) -> MadgwickSettings:
        """The gains of an estimation section."""
        return cls(
            est.madgwick_beta,
            est.accel_reject_mps2,
            est.gyro_bias_gain_per_s,
            est.still_gyro_radps,
            est.still_time_s,
            est.imu_max_gap_s,
        )


class MadgwickFilter:
    """Orientation from gyro + accelerometer (+ magnetometer) samples.

    Args:
        config: the estimation section: the gains (``configure`` takes new ones) and
            ``imu_history_s``, the ring of samples kept (fixed: it needs a restart).
    """

    def __init__(self, config: EstimationConfig) -> None:
        capacity = max(16, math.ceil(config.imu_history_s * _RING_RATE_HZ))
        self._ring = np.zeros((capacity, k.RING_COLUMNS), dtype=np.float64)
        # The filter state, then its params, in one array (see madgwick_ingest).
        self._state_and_params = np.zeros(k.STATE_SIZE + k.PARAM_SIZE, dtype=np.float64)
        self._state = self._state_and_params[: k.STATE_SIZE]
        self._params = self._state_and_params[k.STATE_SIZE :]
        self._mean = np.zeros(3, dtype=np.float64)
        self.configure(config)
        self.reset()

    def reset(self) -> None:
        """Forget orientation, bias and history; the next sample re-initializes."""
        self._state[:] = 0.0
        self._state[k.LAST_STAMP] = math.nan
        self._ring[:] = 0.0

    def configure(self, config: EstimationConfig) -> None:
        """Apply changed gains without losing the orientation."""
        self._params[:] = astuple(MadgwickSettings.of(config))

    @property
    def settings(self) -> MadgwickSettings:
        """The gains the kernels run with now (read back from their parameter array)."""
        return MadgwickSettings(*(float(v) for v in self._params))

    def update(self, imu: Imu) -> bool:
        """Take one sample; returns False if it was not newer than the previous one."""
        g = imu.gyro_radps
        a = imu.accel_mps2
        m = imu.mag_ut or _NO_MAG
        return bool(
            k.madgwick_ingest(
                self._state_and_params,
                self._ring,
                imu.stamp,
                g[0],
                g[1],
                g[2],
                a[0],
                a[1],
                a[2],
                m[0],
                m[1],
                m[2],
            )
        )

    def window_mean(self, end_s: float, length_s: float) -> ImuWindow | None:
        """Means of the samples stamped in (end_s - length_s, end_s], or None if there are none."""
        state = self._state
        n = k.imu_window_mean(
            self._ring,
            int(state[k.RING_HEAD]),
            int(state[k.RING_FILL]),
            end_s - length_s,
            end_s,
            self._mean,
        )
        if n == 0:
            return None
        mean = self._mean
        return ImuWindow(float(mean[0]), float(mean[1]), float(mean[2]), int(n))

    @property
    def initialized(self) -> bool:
        """True once a sample has set the orientation."""
        return bool(self._state[8])

    @property
    def quaternion(self) -> tuple[float, float, float, float]:
        """(w, x, y, z) rotating the IMU frame into the earth frame (z up)."""
        s = self._state
        return float(s[0]), float(s[1]), float(s[2]), float(s[3])

    @property
    def gyro_bias_radps(self) -> Vector3:
        """[rad/s] the gyro bias learned so far."""
        s = self._state
        return Vector3(float(s[4]), float(s[5]), float(s[6]))

    @property
    def last_stamp(self) -> float:
        """[s] stamp of the newest sample used (NaN before any)."""
        return float(self._state[k.LAST_STAMP])

    @property
    def counters(self) -> dict[str, int]:
        """Samples skipped as out of order, and gaps clamped."""
        return {
            "imu_out_of_order": int(self._state[k.OUT_OF_ORDER]),
            "imu_gaps": int(self._state[k.GAPS]),
        }
