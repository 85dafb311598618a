"""Seeded perturbations of a laser log, to test that SLAM's defaults hold on worse data.

Each perturbation stands for a weaker robot than the one that recorded the log:

- ``drop``: 10 % of the scans lost (a busy USB bus, a driver that skips);
- ``odometry``: wheels 5 % long and a heading that drifts 2°/min (worn tyres, a gyro-less
  base); the odometry is rebuilt from its own increments with both errors;
- ``noise``: Gaussian range noise, standard deviation 3 cm (a cheap lidar);
- ``half_beams``: every other beam (half the angular resolution);
- ``range8``: nothing beyond 8 m (a 8 m lidar; longer readings become no-returns).

The same log, kind and seed give the same scans.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterable, Iterator

import numpy as np

from navd.geometry import Pose2
from navd.offline.logfiles import LogScan

__all__ = ["PERTURBATIONS", "perturb"]

PERTURBATIONS = ("drop", "odometry", "noise", "half_beams", "range8")

DROP_SHARE = 0.10
ODOMETRY_SCALE = 1.05
HEADING_DRIFT_RAD_PER_S = math.radians(2.0) / 60.0
RANGE_NOISE_M = 0.03
SHORT_RANGE_M = 8.0


def perturb(scans: Iterable[LogScan], kind: str, seed: int = 0) -> Iterator[LogScan]:
    """``scans`` with the perturbation ``kind`` (one of PERTURBATIONS) applied.

    Raises:
        ValueError: an unknown kind (naming the known ones), at once.
    """
    if kind not in PERTURBATIONS:
        raise ValueError(f"unknown perturbation {kind!r}: choose one of {', '.join(PERTURBATIONS)}")
    if kind == "odometry":
        return _odometry(scans)
    return _per_scan(scans, kind, np.random.default_rng(seed))


def _per_scan(scans: Iterable[LogScan], kind: str, rng: np.random.Generator) -> Iterator[LogScan]:
    for scan in scans:
        if kind == "drop":
            if rng.random() >= DROP_SHARE:
                yield scan
        elif kind == "noise":
            ranges = scan.ranges + rng.normal(0.0, RANGE_NOISE_M, scan.ranges.shape)
            yield dataclasses.replace(scan, ranges=np.maximum(ranges, 0.0))
        elif kind == "half_beams":
            yield dataclasses.replace(
                scan, ranges=scan.ranges[::2].copy(), angle_increment=2.0 * scan.angle_increment
            )
        else:  # range8
            yield dataclasses.replace(
                scan,
                ranges=np.where(scan.ranges > SHORT_RANGE_M, math.inf, scan.ranges),
                range_max=min(scan.range_max, SHORT_RANGE_M),
            )


def _odometry(scans: Iterable[LogScan]) -> Iterator[LogScan]:
    """The odometry rebuilt from its increments: each 5 % longer, and each turned by the
    heading drift over its time (so later motion goes the drifted way, as on a robot)."""
    last: LogScan | None = None
    built: Pose2 | None = None
    for scan in scans:
        if scan.odom is None:
            yield scan
            continue
        if last is None or last.odom is None or built is None:
            built = scan.odom
        else:
            step = last.odom.between(scan.odom)
            drift = HEADING_DRIFT_RAD_PER_S * (scan.stamp - last.stamp)
            built = built.compose(
                Pose2(step.x * ODOMETRY_SCALE, step.y * ODOMETRY_SCALE, step.yaw + drift)
            )
        last = scan
        yield dataclasses.replace(scan, odom=built)
