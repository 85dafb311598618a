"""The angle wrap for numba kernels: the twin of ``angles.wrap_angle``."""

from __future__ import annotations

import math

from numba import njit

__all__ = ["wrap"]


@njit(cache=True, nogil=True)
def wrap(angle: float) -> float:
    """``angle`` [rad] wrapped into [-pi, pi): (a + pi) mod 2 pi - pi."""
    return (angle + math.pi) % (2.0 * math.pi) - math.pi
