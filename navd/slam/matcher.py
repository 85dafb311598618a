"""Correlative scan matching (seed Appendix A), by branch and bound.

For every rotation in the window, the scan points are projected into the likelihood field
and every translation in the window is scored by the sum of field values under the points.
Translations are grouped in blocks of 8 x 8, split into 4 x 4, 2 x 2 and single cells; a
block's upper bound comes from the field's sliding maximum over its size, so blocks are
expanded best-first and the search ends at the first single translation taken off the
queue: the result is the exhaustive optimum at a fraction of the cost (Olson 2009; the
multi-level form of Hess et al. 2016). The optimum is refined below one cell and one
angular step by parabolic fits, and the covariance comes from the curvature of the response
there.

A motion prior can weigh in (Olson 2009 multiplies the scan's likelihood by the motion
model's): each candidate's mean score loses ``prior_weight_per_m2 * d^2 +
prior_weight_per_rad2 * dyaw^2`` for its distance from the prior. Where the scan pins the
pose down this moves the optimum by a few percent of the prior's error at most; where it
does not (a featureless corridor, seen along its length) the prior decides instead of
whichever equal score the search met first. Along the scan's weak axis
(``navd.slam.weak_axis``: a corridor's length) the pull is stronger by up to
``prior_axis_weight_per_m2 * d_along^2``: in full where the scan's surfaces hold nothing
along it, tapering to nothing where they hold ``WEAK_AXIS_RATIO`` of what they hold across.
There a scan matched onto the map built so far is drawn back toward where the map was
drawn from (``navd.slam.weak_axis`` says why), and the wheels, not the walls, know how far
the robot went.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from navd.geometry import Pose2
from navd.slam import _grid_kernels as k
from navd.slam.likelihood_field import FIELD_PEAK, LikelihoodField
from navd.slam.weak_axis import weak_axis

__all__ = ["CorrelativeMatcher", "Match", "rival_ratio"]

FloatArray = npt.NDArray[np.float64]
# The coarsest blocks of translations ``rival_ratio`` bounds are 2**RIVAL_LEVELS cells on a
# side: the matcher's own levels, whose bounds a field it searched holds already (a field
# made for the check alone, as the lost search's, makes three). Fixed: the kernel is
# compiled for one number of levels (the warm-up's), never again on a live scan.
RIVAL_LEVELS = 3
# The weak axis's extra pull is full when the scan's surfaces hold nothing along it and none
# when they hold this share of what they hold across it (linear between). (0.5: aces 0.0388
# m, fr-clinic 0.126 m; 0.4: 0.0409 and 0.968 m, a long loop missed; docs/slam.md.)
WEAK_AXIS_RATIO = 0.5


@dataclass(frozen=True, slots=True)
class Match:
    """The best pose found for a scan.

    Attributes:
        pose: the pose of the robot in the field's frame.
        covariance: 3x3 covariance of (x [m], y [m], yaw [rad]).
        score: mean field value under the points at the best pose, in [0, 1].
        blocks: translation blocks split by the search (its cost).
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
        levels: the coarsest blocks of translations are 2**levels cells on a side.
        response_gain: [1] how sharply the score (a mean in [0, 1]) is read as a likelihood
            when turning its curvature into a covariance.
        prior_weight_per_m2: [1/m^2] mean score lost per squared metre from the prior.
        prior_weight_per_rad2: [1/rad^2] mean score lost per squared radian from the prior.
        prior_axis_weight_per_m2: [1/m^2] mean score lost per squared metre from the prior
            along the scan's weak axis, on top of ``prior_weight_per_m2`` (scaled down as
            the axis is held more firmly; see the module docstring).
        point_spacing_m: [m] the spacing of the points matched (the voxel size they were
            thinned to), for telling surfaces from gaps in the weak axis.
    """

    def __init__(
        self,
        *,
        search_xy_m: float,
        search_yaw_rad: float,
        angle_step_rad: float | None = None,
        reach_m: float = 8.0,
        levels: int = 3,
        response_gain: float = 400.0,
        prior_weight_per_m2: float = 0.0,
        prior_weight_per_rad2: float = 0.0,
        prior_axis_weight_per_m2: float = 0.0,
        point_spacing_m: float = 0.1,
    ) -> None:
        self.search_xy_m = search_xy_m
        self.search_yaw_rad = search_yaw_rad
        self.angle_step_rad = angle_step_rad
        self.reach_m = reach_m
        self.levels = levels
        self.response_gain = response_gain
        self.prior_weight_per_m2 = prior_weight_per_m2
        self.prior_weight_per_rad2 = prior_weight_per_rad2
        self.prior_axis_weight_per_m2 = prior_axis_weight_per_m2
        self.point_spacing_m = point_spacing_m

    def match(self, field: LikelihoodField, points: FloatArray, prior: Pose2) -> Match:
        """The best pose of ``points`` (robot frame, N x 2 [m]) near ``prior``."""
        res = field.resolution
        step = self.angle_step_rad or res / self.reach_m
        n_steps = max(1, math.ceil(self.search_yaw_rad / step))
        angles = prior.yaw + step * np.arange(-n_steps, n_steps + 1, dtype=np.float64)
        cosines, sines = np.cos(angles), np.sin(angles)
        px, py, tx, ty = field.in_cells(points, prior)
        limit = max(1, math.ceil(self.search_xy_m / res))
        # The prior's pull, in summed-score units: per squared cell and per angle.
        n = px.size
        per_cell2 = n * self.prior_weight_per_m2 * res * res
        turn_cost = n * self.prior_weight_per_rad2 * (angles - prior.yaw) ** 2
        weak_x, weak_y, weak_per_m2 = self._weak_pull(points, prior.yaw)
        bounds = tuple(field.bound(1 << level) for level in range(self.levels + 1))
        a, dx, dy, score, blocks = k.branch_and_bound(
            bounds,
            px,
            py,
            cosines,
            sines,
            tx,
            ty,
            limit,
            turn_cost,
            per_cell2,
            -math.inf,
            FIELD_PEAK,
            weak_x,
            weak_y,
            n * weak_per_m2 * res * res,
        )
        best = (max(a, 0), dx, dy, score)
        scan = _Projected(px, py, angles, tx, ty)
        return self._refine(field, scan, best, blocks)

    def _weak_pull(self, points: FloatArray, yaw: float) -> tuple[float, float, float]:
        """The scan's weak axis in the field's frame (the scan turned by ``yaw`` [rad]) and
        the extra pull along it [1/m^2] (0: none, the axis then means nothing)."""
        if self.prior_axis_weight_per_m2 <= 0.0:
            return 1.0, 0.0, 0.0
        axis = weak_axis(points, self.point_spacing_m)
        if axis is None:
            return 1.0, 0.0, 0.0
        share = max(0.0, 1.0 - axis.ratio / WEAK_AXIS_RATIO)
        turned = axis.rotated(yaw)
        return turned.x, turned.y, self.prior_axis_weight_per_m2 * share

    def _refine(
        self,
        field: LikelihoodField,
        scan: _Projected,
        best: tuple[int, int, int, float],
        blocks: int,
    ) -> Match:
        px, py, angles, tx, ty = scan
        n_points = px.size
        a, dx, dy, score = best
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


def rival_ratio(
    field: LikelihoodField,
    points: FloatArray,
    pose: Pose2,
    *,
    radius_m: float,
    exclude_m: float,
) -> float:
    """How well the best rival of ``pose`` scores, as a share of ``pose``'s own score.

    Rivals are the translations within ``radius_m`` of ``pose`` but farther than
    ``exclude_m`` from it, at ``pose``'s rotation. A ratio near 1 means the scan fits
    elsewhere about as well (a corridor seen along its length, a row of equal doors): the
    match is ambiguous. 1.0 if ``pose`` itself scores nothing.
    """
    res = field.resolution
    px, py, tx, ty = field.in_cells(points, pose)
    limit = max(1, math.ceil(radius_m / res))
    c, s = math.cos(pose.yaw), math.sin(pose.yaw)
    own = float(k.fine_scores(field.values, px, py, c, s, tx, ty, 0, 0, 1, 1)[0, 0])
    if own <= 0.0:
        return 1.0
    offsets = np.arange(-limit, limit + 1) * res
    distance = np.hypot(offsets[None, :], offsets[:, None])
    allowed = (distance > exclude_m) & (distance <= radius_m)
    # Searched best-first over blocks (the field's bounds, as the matcher's), not cell by
    # cell: the window is several metres wide.
    bounds = tuple(field.bound(1 << level) for level in range(RIVAL_LEVELS + 1))
    return k.best_among(bounds, px, py, c, s, tx, ty, allowed) / own
