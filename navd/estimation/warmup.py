"""Compile (or load from the cache) the estimation kernels before the first sample: the
Madgwick filter and the UKF run on the event loop, where a first compile would stall it for
seconds."""

from __future__ import annotations

import math

import numpy as np

from navd.config import EstimationConfig
from navd.estimation._ukf_kernels import propagate
from navd.estimation.history import Snapshot
from navd.estimation.madgwick import MadgwickFilter
from navd.estimation.motion_model import STATE_SIZE, ProcessNoise, Row
from navd.estimation.ukf import Measurement, PoseUkf, UkfSettings
from navd.lifecycle.messages import Imu, Vector3

__all__ = ["warm_up"]


def warm_up(config: EstimationConfig) -> None:
    """Run a throwaway Madgwick filter over a few samples (with and without a magnetometer)
    and read a window of them back; step a throwaway UKF without and with a measurement,
    through the gate and past it; predict a state between events (the estimate). (pyproj's
    database is opened on the event loop instead, which projects the fixes: see
    ``geo.open_projections_here``.)"""
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
    ukf = PoseUkf(UkfSettings.of(config))
    ukf.set_state(np.zeros(STATE_SIZE), np.eye(STATE_SIZE))
    rows = (Row.X, Row.Y, Row.YAW, Row.YAW_RATE, Row.ACCEL_FORWARD, Row.VELOCITY_LEFT)
    measurement = Measurement(rows=rows, z=np.zeros(6), r=np.eye(6), gated_rows=3)
    ukf.step(0.1, None, math.inf)
    ukf.step(0.1, measurement, math.inf)
    ukf.step(0.1, measurement, 0.0)  # refused by the gate: the tail rows alone
    # the estimate's prediction, on a history's read-only arrays (a type of their own)
    latest = Snapshot.of(0.0, np.zeros(STATE_SIZE), np.eye(STATE_SIZE))
    propagate(latest.x, latest.p, 0.04, ProcessNoise(1.0, 1.0).polynomial)
