"""The direction a scan pins the robot down least: along a corridor seen down its length.

A scan matched onto a map is held in place by its surfaces: a wall holds the pose across
it, not along it. Each short segment between neighbouring points (a piece of surface) has a
unit normal n; summed over the scan, the outer products n nᵀ make a 2 x 2 matrix whose
eigenvalues say how much of the surface holds each direction. In a corridor its smaller
eigenvalue, along the corridor, is a small share of the larger (a wall's doors and the far
end are all that hold it); in a room both are alike.

Along the weak direction a scan matched onto the map built so far is drawn back toward
where the map was drawn from: its far ends fit better moved back onto walls drawn already,
and its cells onto those of the same view drawn a step ago (a corridor 2 m wide drawn every
0.2 m: a 0.2 m step lost whole, ``tests/slam/test_matcher.py``). The tracking matcher lets
the odometry pull harder along it (``slam.prior_axis_weight_per_m2``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

__all__ = ["WeakAxis", "weak_axis"]

FloatArray = npt.NDArray[np.float64]

# Neighbouring points farther apart than this many times their spacing (the voxel size the
# scan was thinned to) are not one surface (a door, a corner seen past, the jump from a near
# wall to a far one): 0.3 m at the default 0.1 m voxels, a wall seen at a slant included.
SURFACE_GAP_SPACINGS = 3.0
# A scan with fewer surface segments than this has no weak axis (too little to tell).
MIN_SEGMENTS = 10


@dataclass(frozen=True, slots=True)
class WeakAxis:
    """The direction a scan's surfaces hold least.

    Attributes:
        x, y: unit vector of the direction, in the scan's frame (its sign means nothing).
        ratio: [1] how much the surfaces hold it, as a share of the direction across it
            (the smaller eigenvalue over the larger): near 0 in a corridor, near 1 in a room.
    """

    x: float
    y: float
    ratio: float

    def rotated(self, yaw: float) -> WeakAxis:
        """The same axis in a frame where the scan's frame is turned by ``yaw`` [rad]."""
        c, s = math.cos(yaw), math.sin(yaw)
        return WeakAxis(c * self.x - s * self.y, s * self.x + c * self.y, self.ratio)


def weak_axis(points: FloatArray, spacing_m: float) -> WeakAxis | None:
    """The weak axis of a scan's points.

    Args:
        points: N x 2 [m], in beam order (as ``voxel_downsample`` keeps them).
        spacing_m: [m] the points' spacing along a surface (the voxel size they were thinned
            to); neighbours up to ``SURFACE_GAP_SPACINGS`` times it apart make a surface.

    Returns:
        The axis, or None if fewer than ``MIN_SEGMENTS`` neighbouring pairs make a surface.
    """
    if points.shape[0] < 2:
        return None
    steps = np.diff(points, axis=0)
    length = np.hypot(steps[:, 0], steps[:, 1])  # NaN compares false: never a surface
    surface = (length > 0.0) & (length <= SURFACE_GAP_SPACINGS * spacing_m)
    if np.count_nonzero(surface) < MIN_SEGMENTS:
        return None
    # the normal of a step (dx, dy) is (-dy, dx) / length
    nx = -steps[surface, 1] / length[surface]
    ny = steps[surface, 0] / length[surface]
    xx, xy, yy = float(nx @ nx), float(nx @ ny), float(ny @ ny)
    # eigenvalues of [[xx, xy], [xy, yy]] and the smaller one's eigenvector
    mean, half_gap = 0.5 * (xx + yy), math.hypot(0.5 * (xx - yy), xy)
    small, large = mean - half_gap, mean + half_gap
    angle = 0.5 * math.atan2(2.0 * xy, xx - yy) + 0.5 * math.pi  # across the strong one
    return WeakAxis(math.cos(angle), math.sin(angle), max(0.0, small) / large)
