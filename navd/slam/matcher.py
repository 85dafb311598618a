"""Correlative scan matching (seed Appendix A), two-level branch and bound.

For every rotation in the window, the scan points are projected into the likelihood field
and every translation in the window is scored by the sum of field values under the points.
Translations are grouped in f x f blocks; a block's upper bound comes from the field's
sliding maximum, so blocks are expanded best-first and the search stops when no remaining
block can beat the best exact score: the result is the exhaustive optimum at a fraction of
the cost. The optimum is refined below one cell and one angular step by parabolic fits, and
the covariance comes from the curvature of the response there.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from navd.slam import _grid_kernels as k
from navd.slam.occupancy import LikelihoodField
from navd.slam.pose import Pose2

__all__ = ["CorrelativeMatcher", "Match"]

FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True, slots=True)
class Match:
    """The best pose found for a scan.

    Attributes:
        pose: the pose of the robot in the field's frame.
        covariance: 3x3 covariance of (x [m], y [m], yaw [rad]).
        score: mean field value under the points at the best pose, in [0, 1].
        blocks: translation blocks scored exactly (the search's cost).
    """

    pose: Pose2
    covariance: FloatArray
    score: float
    blocks: int


class _Projected(NamedTuple):
    """A scan prepared for scoring: points in cell units, the rotations, the prior cell."""

    px: FloatArray
    py: FloatArray
    angles: FloatArray
    tx: float
    ty: float


def _parabola_peak(minus: float, center: float, plus: float) -> tuple[float, float]:
    """Offset in [-0.5, 0.5] steps of the vertex through three samples, and the curvature."""
    curvature = minus - 2.0 * center + plus
    if curvature >= 0.0:
        return 0.0, 0.0
    offset = 0.5 * (minus - plus) / curvature
    return max(-0.5, min(0.5, offset)), curvature


class CorrelativeMatcher:
    """Finds the pose of a scan in a likelihood field around a prior.

    Args:
        search_xy_m: [m] half-width of the translation window.
        search_yaw_rad: [rad] half-width of the rotation window.
        angle_step_rad: [rad] rotation step (None: one cell at ``reach_m``).
        reach_m: [m] typical point distance, for the default angle step.
        block: translation block size in cells (the coarse level).
        response_gain: [1] how sharply the score (a mean in [0, 1]) is read as a likelihood
            when turning its curvature into a covariance.
    """

    def __init__(
        self,
        *,
        search_xy_m: float,
        search_yaw_rad: float,
        angle_step_rad: float | None = None,
        reach_m: float = 8.0,
        block: int = 4,
        response_gain: float = 400.0,
    ) -> None:
        self.search_xy_m = search_xy_m
        self.search_yaw_rad = search_yaw_rad
        self.angle_step_rad = angle_step_rad
        self.reach_m = reach_m
        self.block = block
        self.response_gain = response_gain

    def match(self, field: LikelihoodField, points: FloatArray, prior: Pose2) -> Match:
        """The best pose of ``points`` (robot frame, N x 2 [m]) near ``prior``."""
        res = field.resolution
        step = self.angle_step_rad or res / self.reach_m
        n_steps = max(1, math.ceil(self.search_yaw_rad / step))
        angles = prior.yaw + step * np.arange(-n_steps, n_steps + 1, dtype=np.float64)
        cosines, sines = np.cos(angles), np.sin(angles)
        px = np.ascontiguousarray(points[:, 0] / res)
        py = np.ascontiguousarray(points[:, 1] / res)
        tx = (prior.x - field.origin_x) / res - 0.5
        ty = (prior.y - field.origin_y) / res - 0.5
        limit = max(1, math.ceil(self.search_xy_m / res))
        f = self.block
        starts_1d = np.arange(-limit, limit + 1, f)
        starts = np.array([(dx, dy) for dy in starts_1d for dx in starts_1d], dtype=np.int64)
        bounds = k.coarse_scores(field.bound(f), px, py, cosines, sines, tx, ty, starts, f)
        order = np.argsort(bounds, axis=None)[::-1]
        best = (-1.0, 0, 0, 0)  # score, angle index, dx, dy
        blocks = 0
        for flat in order:
            a, b = divmod(int(flat), starts.shape[0])
            if bounds[a, b] <= best[0]:
                break
            dx0, dy0 = int(starts[b, 0]), int(starts[b, 1])
            nx = min(f, limit - dx0 + 1)
            ny = min(f, limit - dy0 + 1)
            scores = k.fine_scores(
                field.values, px, py, cosines[a], sines[a], tx, ty, dx0, dy0, nx, ny
            )
            blocks += 1
            j, i = np.unravel_index(int(np.argmax(scores)), scores.shape)
            if scores[j, i] > best[0]:
                best = (float(scores[j, i]), a, dx0 + int(i), dy0 + int(j))
        scan = _Projected(px, py, angles, tx, ty)
        return self._refine(field, scan, best, blocks)

    def _refine(
        self,
        field: LikelihoodField,
        scan: _Projected,
        best: tuple[float, int, int, int],
        blocks: int,
    ) -> Match:
        px, py, angles, tx, ty = scan
        n_points = px.size
        score, a, dx, dy = best
        res = field.resolution
        yaw = float(angles[a])
        around = k.fine_scores(
            field.values, px, py, math.cos(yaw), math.sin(yaw), tx, ty, dx - 1, dy - 1, 3, 3
        )
        n = max(n_points, 1)
        sx, cx = _parabola_peak(around[1, 0] / n, around[1, 1] / n, around[1, 2] / n)
        sy, cy = _parabola_peak(around[0, 1] / n, around[1, 1] / n, around[2, 1] / n)
        step = float(angles[1] - angles[0]) if angles.size > 1 else 0.0
        sa, ca = 0.0, 0.0
        if 0 < a < angles.size - 1:
            side = [
                float(
                    k.fine_scores(
                        field.values,
                        px,
                        py,
                        math.cos(float(angles[i])),
                        math.sin(float(angles[i])),
                        tx,
                        ty,
                        dx,
                        dy,
                        1,
                        1,
                    )[0, 0]
                )
                / n
                for i in (a - 1, a + 1)
            ]
            sa, ca = _parabola_peak(side[0], score / n, side[1])
        # The optimum in world units: cell offsets, then the sub-step vertex.
        x = (tx + 0.5 + dx + sx) * res + field.origin_x
        y = (ty + 0.5 + dy + sy) * res + field.origin_y
        pose = Pose2(float(x), float(y), math.remainder(yaw + sa * step, 2.0 * math.pi))
        gain = self.response_gain

        def variance(curvature: float, unit: float, floor: float, ceiling: float) -> float:
            if curvature >= 0.0:
                return ceiling**2
            value = unit**2 / (gain * -curvature)
            return min(max(value, floor**2), ceiling**2)

        cov = np.diag(
            [
                variance(cx, res, res / 4, self.search_xy_m),
                variance(cy, res, res / 4, self.search_xy_m),
                variance(ca, step or 1.0, (step or 0.01) / 4, self.search_yaw_rad),
            ]
        )
        return Match(pose, cov, score / n, blocks)
