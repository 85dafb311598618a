"""Where scan points are likely to fall: a blurred image of a grid's occupied cells (each
occupied cell stamped with a Gaussian, the largest stamp kept), with the sliding maxima the
branch-and-bound searches bound a scan's score by."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from navd.geometry import Pose2
from navd.slam import _grid_kernels as k

__all__ = ["FIELD_PEAK", "LikelihoodField", "gaussian_kernel"]

F32 = npt.NDArray[np.float32]
F64 = npt.NDArray[np.float64]

# The largest value a likelihood field cell holds: the centre of a Gaussian stamp, exp(0)
# (stamps are kept by their maximum, never added); searches bound a scan's score with it.
FIELD_PEAK = 1.0


@dataclass
class LikelihoodField:
    """Where scan points are likely to fall: a blurred image of the occupied cells.

    Attributes:
        values: float32 [rows, cols] in [0, 1].
        origin_x, origin_y: [m] corner of cell (0, 0).
        resolution: [m] cell size.
    """

    values: F32
    origin_x: float
    origin_y: float
    resolution: float
    _bounds: dict[int, F32] = field(default_factory=dict)

    def __post_init__(self) -> None:
        # The kernels take the values and their bounds as one tuple of C-ordered float32
        # arrays (``bound(1)`` is ``values`` itself): another layout would be compiled anew.
        self.values = np.ascontiguousarray(self.values, dtype=np.float32)

    def bound(self, block: int) -> F32:
        """The sliding maximum over ``block`` x ``block`` cells, a power of two (cached;
        ``bound(1)`` is ``values`` itself, so neither may be written: the fine map, which
        stamps into a field's values, hands out a new field with nothing cached).

        Each comes from the one half its size: the maximum over [u, u + 2h) is that of
        [u, u + h) and [u + h, u + 2h), so a search over all powers of two costs one pass per
        level instead of ``block`` per level.

        Raises:
            ValueError: ``block`` is not a power of two.
        """
        cached = self._bounds.get(block)
        if cached is None:
            if block < 1 or block & (block - 1):
                raise ValueError(f"a field's bound is over a power of two cells, not {block}")
            if block == 1:
                cached = self.values  # the maximum over one cell is the cell
            else:
                cached = k.doubled_max(self.bound(block // 2), block // 2)
            self._bounds[block] = cached
        return cached

    def in_cells(self, points: F64, pose: Pose2) -> tuple[F64, F64, float, float]:
        """``points`` (robot frame, N x 2 [m]) and ``pose``'s position in cell units, as the
        scoring kernels take them: px, py (contiguous) and the offset tx, ty of ``pose`` from
        the centre of cell (0, 0), fraction included."""
        res = self.resolution
        px = np.ascontiguousarray(points[:, 0] / res)
        py = np.ascontiguousarray(points[:, 1] / res)
        tx = (pose.x - self.origin_x) / res - 0.5
        ty = (pose.y - self.origin_y) / res - 0.5
        return px, py, tx, ty


def gaussian_kernel(sigma_m: float, resolution: float) -> F32:
    """exp(-d² / (2 sigma²)) over a square of half-width ceil(2 sigma / res) cells."""
    r = max(1, math.ceil(2.0 * sigma_m / resolution))
    d = np.arange(-r, r + 1) * resolution
    d2 = d[:, None] ** 2 + d[None, :] ** 2
    return np.exp(-0.5 * d2 / sigma_m**2).astype(np.float32)
