"""Compile (or load from the cache) the estimation kernels before the first IMU sample: the
Madgwick filter runs on the event loop, where a first compile would stall it for a second."""

from __future__ import annotations

from navd.config import EstimationConfig
from navd.estimation.madgwick import MadgwickFilter
from navd.lifecycle.messages import Imu, Vector3

__all__ = ["warm_up"]


def warm_up(config: EstimationConfig) -> None:
    """Run a throwaway filter over a few samples (with and without a magnetometer) and read
    a window of them back."""
    madgwick = MadgwickFilter(config)
    for k in range(4):
        stamp = 0.01 * k
        madgwick.update(
            Imu(
                stamp=stamp,
                received=stamp,
                device_id="warm-up",
                gyro_radps=Vector3(0.0, 0.0, 0.1),
                accel_mps2=Vector3(0.0, 0.0, 9.81),
                mag_ut=Vector3(20.0, 0.0, -40.0) if k % 2 else None,
            )
        )
    madgwick.window_mean(0.03, 0.02)
