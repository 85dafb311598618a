"""Where the robot stands from its ranges to beacons at known places, before anything else
has placed it: the place that all ranges, or all but one, agree on (a reflection is one bad
range), found by weighted least squares."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import numpy.typing as npt

from navd.config import BeaconPlaceConfig

__all__ = [
    "RANGE_START_BEACONS",
    "RANGE_START_S",
    "RANGE_START_SIGMAS",
    "RangeStart",
    "agreeing_place",
    "place_from_ranges",
    "trilaterate",
]

FloatArray = npt.NDArray[np.float64]

# [s] ranges to known beacons this recent together place the robot when nothing else has.
RANGE_START_S = 1.0
# Known beacons whose ranges start the filter (three: the place is not mirrored; four when
# there are: one bad range is then seen and left out).
RANGE_START_BEACONS = 3
# A range farther than this many of its sigmas from the place they agree on is left out.
RANGE_START_SIGMAS = 4.0


class RangeStart:
    """The latest range to each known beacon, kept until together they place the robot."""

    def __init__(self) -> None:
        # by beacon id: stamp [s], range [m], its std [m]
        self._latest: dict[str, tuple[float, float, float]] = {}

    def add(
        self,
        beacon_id: str,
        stamp: float,
        range_m: float,
        std_m: float,
        known: Mapping[str, BeaconPlaceConfig],
    ) -> tuple[FloatArray, FloatArray] | None:
        """Keep a range to the known beacon ``beacon_id``; the place [m] and its covariance
        once the latest ranges agree on one (``place_from_ranges``; the ranges are then
        forgotten), else None."""
        self._latest[beacon_id] = (stamp, range_m, std_m)
        found = place_from_ranges(self._latest, known, stamp)
        if found is not None:
            self._latest.clear()
        return found


def place_from_ranges(
    ranges: Mapping[str, tuple[float, float, float]],
    known: Mapping[str, BeaconPlaceConfig],
    stamp: float,
) -> tuple[FloatArray, FloatArray] | None:
    """[m] where the robot stands, and the covariance, from the latest ``ranges`` to beacons
    at ``known`` places (by id: stamp [s], range [m], its std [m]) within RANGE_START_S of
    ``stamp``; None until enough of them agree (``agreeing_place``). With a fourth beacon
    known it waits for it: three ranges fit a wrong place as well as the right one when one
    of them is a reflection."""
    recent = [(known[b], r, std) for b, (t, r, std) in ranges.items() if stamp - t <= RANGE_START_S]
    needed = min(max(len(known), RANGE_START_BEACONS), 4)
    if len(recent) < needed:
        return None
    points = np.array([[p.x_m, p.y_m] for p, _, _ in recent])
    distances = np.array([r for _, r, _ in recent])
    stds = np.array([std for _, _, std in recent])
    return agreeing_place(points, distances, stds)


def agreeing_place(
    points_m: FloatArray, ranges_m: FloatArray, stds_m: FloatArray
) -> tuple[FloatArray, FloatArray] | None:
    """[m] the place (and its covariance) that all ranges, or all but one, agree on within
    RANGE_START_SIGMAS of their noise: each range is left out in turn (a reflection pulls a
    fit of all of them off the place, and three ranges fit a wrong place as well as the
    right one), and the fit that the most ranges agree with, then the closest, wins."""
    n = points_m.shape[0]
    best: tuple[int, float, FloatArray, FloatArray] | None = None
    subsets = [np.arange(n)] + ([np.delete(np.arange(n), k) for k in range(n)] if n > 3 else [])
    for subset in subsets:
        solved = trilaterate(points_m[subset], ranges_m[subset], stds_m[subset])
        if solved is None:
            continue
        xy, cov, _ = solved
        misfit = (ranges_m - np.hypot(*(xy - points_m).T)) / stds_m
        agree = np.abs(misfit) <= RANGE_START_SIGMAS
        if not agree[subset].all() or agree.sum() < max(n - 1, RANGE_START_BEACONS):
            continue
        score = (int(agree.sum()), -float((misfit[agree] ** 2).sum()))
        if best is None or score > best[:2]:
            best = (*score, xy, cov)
    return None if best is None else (best[2], best[3])


def trilaterate(
    points_m: FloatArray, ranges_m: FloatArray, stds_m: FloatArray
) -> tuple[FloatArray, FloatArray, FloatArray] | None:
    """[m] the place whose distances to ``points_m`` best fit ``ranges_m`` (weighted least
    squares by Gauss-Newton from the points' centroid), its covariance, and each range's
    misfit in its own sigmas; None if the points are in a line or it does not settle."""
    if np.linalg.matrix_rank(points_m[1:] - points_m[0], tol=1e-3) < 2:
        return None
    weights = 1.0 / stds_m**2
    xy = points_m.mean(axis=0)
    for _ in range(30):
        offsets = xy - points_m
        distances = np.maximum(np.hypot(*offsets.T), 1e-6)
        jacobian = offsets / distances[:, None]
        normal = jacobian.T @ (weights[:, None] * jacobian)
        if np.linalg.cond(normal) > 1e9:
            return None
        cov = np.linalg.inv(normal)
        step = cov @ (jacobian.T @ (weights * (ranges_m - distances)))
        xy = xy + step
        if float(np.hypot(*step)) < 1e-4:
            distances = np.hypot(*(xy - points_m).T)
            return xy, cov, (ranges_m - distances) / stds_m
    return None
