"""Seeded perturbations of a laser log, to test that SLAM's defaults hold on worse data.

Each perturbation stands for a weaker robot, or a harder one, than the one that recorded the
log:

- ``drop``: 10 % of the scans lost (a busy USB bus, a driver that skips);
- ``every2``, ``every3``: only every 2nd or 3rd scan (a slow lidar, or a fast robot: two or
  three times the motion between scans);
- ``odometry``: wheels 5 % long and a heading that drifts 2°/min (worn tyres, a gyro-less
  base); the odometry is rebuilt from its own increments with both errors;
- ``odometry_spikes``: on 1 % of the steps the odometry jumps, 1 m sideways or 1.5 rad
  round (an encoder glitch: at 5 scans/s, 5 m/s or 7.5 rad/s), and keeps the jump after;
- ``noise``: Gaussian range noise, standard deviation 3 cm (a cheap lidar);
- ``half_beams``: every other beam (half the angular resolution);
- ``fov120``: only the 120° in front (a lidar behind a bumper, or half hidden by a mast);
- ``range8``: nothing beyond 8 m (a 8 m lidar; longer readings become no-returns);
- ``spurious``: 3 % of the readings a spurious 80 m (a lidar that sees through glass, or
  reports its maximum for a weak echo).

Kinds combine with ``+`` (``every3+spurious+odometry_spikes``), applied left to right, each
with its own seed drawn from the one given. The same log, kind and seed give the same scans.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Iterable, Iterator

import numpy as np

from navd.geometry import Pose2
from navd.offline.logfiles import LogScan

__all__ = ["COMBINATIONS", "PERTURBATIONS", "perturb"]

PERTURBATIONS = (
    "drop",
    "every2",
    "every3",
    "odometry",
    "odometry_spikes",
    "noise",
    "half_beams",
    "fov120",
    "range8",
    "spurious",
)
# The combinations the robustness suite runs besides each kind alone: the held-out log's
# conditions (a slow lidar on a fast robot, spurious long returns, odometry with spikes).
COMBINATIONS = (
    "every2+odometry_spikes",
    "every3+spurious+odometry_spikes",
    "every2+half_beams+spurious+odometry_spikes",
)

DROP_SHARE = 0.10
ODOMETRY_SCALE = 1.05
HEADING_DRIFT_RAD_PER_S = math.radians(2.0) / 60.0
SPIKE_SHARE = 0.01  # of odometry steps
SPIKE_M, SPIKE_RAD = 1.0, 1.5  # one spike: this far sideways, or this far round
RANGE_NOISE_M = 0.03
FIELD_OF_VIEW_RAD = math.radians(120.0)
SHORT_RANGE_M = 8.0
SPURIOUS_SHARE = 0.03
SPURIOUS_M = 80.0
SPURIOUS_RANGE_MAX_M = 81.91  # a SICK's no-return reading: the spurious ones stay valid

StepChange = Callable[[Pose2, float], Pose2]  # (odometry step, its seconds) -> the step used


def perturb(scans: Iterable[LogScan], kind: str, seed: int = 0) -> Iterator[LogScan]:
    """``scans`` with the perturbation ``kind`` applied: one of PERTURBATIONS, or several
    joined by ``+``.

    Raises:
        ValueError: an unknown kind (naming the known ones), at once.
    """
    parts = kind.split("+")
    for part in parts:
        if part not in PERTURBATIONS:
            raise ValueError(
                f"unknown perturbation {part!r}: choose one of {', '.join(PERTURBATIONS)}, "
                "or several joined by '+'"
            )
    # One kind alone keeps the seed as given (the figures of record were made so).
    seeds: list[int | np.random.SeedSequence] = (
        list(np.random.SeedSequence(seed).spawn(len(parts))) if len(parts) > 1 else [seed]
    )
    out: Iterable[LogScan] = scans
    for part, part_seed in zip(parts, seeds, strict=True):
        out = _one(out, part, np.random.default_rng(part_seed))
    return iter(out)


def _one(scans: Iterable[LogScan], kind: str, rng: np.random.Generator) -> Iterator[LogScan]:
    if kind == "odometry":
        return _odometry(scans)
    if kind == "odometry_spikes":
        return _odometry_spikes(scans, rng)
    if kind in ("every2", "every3"):
        step = int(kind[-1])
        return (scan for i, scan in enumerate(scans) if i % step == 0)
    return _per_scan(scans, kind, rng)


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
        elif kind == "fov120":
            yield _front(scan, FIELD_OF_VIEW_RAD)
        elif kind == "spurious":
            ranges = scan.ranges.copy()
            ranges[rng.random(ranges.shape) < SPURIOUS_SHARE] = SPURIOUS_M
            yield dataclasses.replace(
                scan, ranges=ranges, range_max=max(scan.range_max, SPURIOUS_RANGE_MAX_M)
            )
        else:  # range8
            yield dataclasses.replace(
                scan,
                ranges=np.where(scan.ranges > SHORT_RANGE_M, math.inf, scan.ranges),
                range_max=min(scan.range_max, SHORT_RANGE_M),
            )


def _front(scan: LogScan, fov_rad: float) -> LogScan:
    """Only the beams within ``fov_rad`` about straight ahead (all of them if the lidar
    sees no wider). A scan from 0 to 2π has its front at both ends: the two are joined."""
    n = scan.ranges.size
    angles = scan.angle_min + scan.angle_increment * np.arange(n)
    inside = np.flatnonzero(
        np.abs(np.arctan2(np.sin(angles), np.cos(angles))) <= fov_rad / 2 + 1e-9
    )
    if inside.size in (0, n):
        return scan
    gaps = np.flatnonzero(np.diff(inside) > 1)
    if gaps.size:  # two arcs: the one at the end comes first, a turn earlier
        cut = int(gaps[0]) + 1
        inside = np.concatenate([inside[cut:], inside[:cut]])
        angle_min = float(angles[inside[0]]) - 2.0 * math.pi
    else:
        angle_min = float(angles[inside[0]])
    return dataclasses.replace(scan, angle_min=angle_min, ranges=scan.ranges[inside].copy())


def _odometry(scans: Iterable[LogScan]) -> Iterator[LogScan]:
    """The odometry rebuilt from its increments: each 5 % longer, and each turned by the
    heading drift over its time (so later motion goes the drifted way, as on a robot)."""

    def worse(step: Pose2, dt: float) -> Pose2:
        drift = HEADING_DRIFT_RAD_PER_S * dt
        return Pose2(step.x * ODOMETRY_SCALE, step.y * ODOMETRY_SCALE, step.yaw + drift)

    return _rebuilt(scans, worse)


def _odometry_spikes(scans: Iterable[LogScan], rng: np.random.Generator) -> Iterator[LogScan]:
    """The odometry rebuilt from its increments, one in SPIKE_SHARE with a spike added:
    half of them SPIKE_M sideways, half SPIKE_RAD round (either sign)."""

    def spiked(step: Pose2, dt: float) -> Pose2:
        if rng.random() >= SPIKE_SHARE:
            return step
        sign = 1.0 if rng.random() < 0.5 else -1.0
        if rng.random() < 0.5:
            return Pose2(step.x, step.y + sign * SPIKE_M, step.yaw)
        return Pose2(step.x, step.y, step.yaw + sign * SPIKE_RAD)

    return _rebuilt(scans, spiked)


def _rebuilt(scans: Iterable[LogScan], change: StepChange) -> Iterator[LogScan]:
    """The odometry rebuilt from its increments, each passed through ``change(step, dt)``."""
    last: LogScan | None = None
    built: Pose2 | None = None
    for scan in scans:
        if scan.odom is None:
            yield scan
            continue
        if last is None or last.odom is None or built is None:
            built = scan.odom
        else:
            built = built.compose(change(last.odom.between(scan.odom), scan.stamp - last.stamp))
        last = scan
        yield dataclasses.replace(scan, odom=built)
