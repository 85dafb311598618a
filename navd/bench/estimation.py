"""Estimation benchmark: Madgwick per sample, UKF per event, and the cost of a late event.

Printed:
- ``madgwick_us_per_sample``: one IMU message through ``MadgwickFilter.update``, Python call
  included (and the share of one core that 1 kHz costs);
- ``ukf_step_us``: the UKF's predict + update for one lidar pose (x, y, yaw, with the three
  IMU rows and the no-sliding row: seven rows, yaw wrapped), median and p95 over a 60 s
  figure-eight, with the number of numerical resets (expected 0); ``pose_event_us`` is the
  whole path of that pose through the estimator (measurement built from the IMU ring, event
  queue, state snapshot);
- ``late_event_ms``: inserting a lidar pose 100 ms late, which rewinds and re-applies what
  came after it, with IMU at 1 kHz, lidar at 10 Hz and wheel odometry at 50 Hz (IMU samples
  are never re-applied: they wait in a ring and are averaged into events at their stamps).
"""

from __future__ import annotations

import statistics
import time

from navd.bench.motion_scenario import FigureEight, SensorSuite, drive
from navd.config import NavdConfig
from navd.estimation import (
    EstimatorSettings,
    FloatArray,
    Insert,
    MadgwickFilter,
    Measurement,
    PoseUkf,
    StateEstimator,
    StepOutcome,
)
from navd.lifecycle import percentile
from navd.lifecycle.messages import Imu, Message, PoseMeasurement, WheelOdometry

__all__ = ["run"]


def _madgwick_us(samples: list[Imu], repeats: int) -> float:
    best = float("inf")
    for _ in range(repeats):
        f = MadgwickFilter(NavdConfig().estimation)
        update = f.update
        start = time.perf_counter()
        for imu in samples:
            update(imu)
        best = min(best, (time.perf_counter() - start) / len(samples) * 1e6)
    return best


class _TimedUkf:
    """Forwards to the estimator's UKF, timing every step."""

    def __init__(self, ukf: PoseUkf) -> None:
        self.ukf = ukf
        self.seconds: list[float] = []

    def set_state(self, x: FloatArray, p: FloatArray) -> None:
        self.ukf.set_state(x, p)

    @property
    def x(self) -> FloatArray:
        return self.ukf.x

    @property
    def p(self) -> FloatArray:
        return self.ukf.p

    @property
    def last_mahalanobis_sq(self) -> float:
        return self.ukf.last_mahalanobis_sq

    def step(self, dt_s: float, measurement: Measurement | None, gate_chi2: float) -> StepOutcome:
        start = time.perf_counter()
        outcome = self.ukf.step(dt_s, measurement, gate_chi2)
        self.seconds.append(time.perf_counter() - start)
        return outcome


def _timed_replay(
    messages: list[Message],
) -> tuple[StateEstimator, list[float], list[float], list[float]]:
    """Feed ``messages`` in arrival order; time pose inserts (on time, late) and UKF steps."""
    estimator = StateEstimator(EstimatorSettings.from_config(NavdConfig()))
    timed = _TimedUkf(estimator.history.ukf)
    estimator.history.ukf = timed  # type: ignore[assignment]
    on_time: list[float] = []
    late: list[float] = []
    for message in messages:
        now = message.received
        if isinstance(message, Imu):
            estimator.add_imu(message)
        elif isinstance(message, WheelOdometry):
            estimator.add_wheel_odometry(message, now)
        elif isinstance(message, PoseMeasurement):
            start = time.perf_counter()
            outcome = estimator.add_pose(message, now)
            elapsed = time.perf_counter() - start
            if outcome is Insert.REPLAYED:
                late.append(elapsed)
            elif outcome is Insert.APPLIED:
                on_time.append(elapsed)
    return estimator, on_time, late, timed.seconds


def run(seconds: float = 60.0) -> dict[str, object]:
    """Run the three measurements over a ``seconds`` long synthetic drive."""
    path = FigureEight()
    imu_only = [m for m in drive(path, SensorSuite(lidar_hz=0.0), 20.0) if isinstance(m, Imu)]
    madgwick_us = _madgwick_us(imu_only, repeats=3)

    estimator, events, _, steps = _timed_replay(drive(path, SensorSuite(), seconds))
    late_drive = drive(path, SensorSuite(wheel_hz=50.0, lidar_delay_s=0.1), seconds)
    late_estimator, _, late, _ = _timed_replay(late_drive)
    counters = late_estimator.counters
    replayed = counters["late_events"]
    reapplied = counters["events_reapplied"]
    assert isinstance(replayed, int) and isinstance(reapplied, int)
    return {
        "madgwick_us_per_sample": round(madgwick_us, 2),
        "madgwick_1khz_core_percent": round(madgwick_us * 1000 / 1e6 * 100, 2),
        "ukf_step_us_median": round(percentile(steps, 50) * 1e6, 1),
        "ukf_step_us_p95": round(percentile(steps, 95) * 1e6, 1),
        "ukf_steps": len(steps),
        "ukf_resets": estimator.counters["resets"],
        "pose_event_us_median": round(percentile(events, 50) * 1e6, 1),
        "late_event_ms_mean": round(statistics.fmean(late) * 1e3, 3),
        "late_event_ms_p95": round(percentile(late, 95) * 1e3, 3),
        "late_events": replayed,
        "events_reapplied_per_late_event": round(reapplied / max(replayed, 1), 2),
    }
