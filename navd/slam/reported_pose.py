"""What may refine the pose a scan is reported at, after the mapper matched it: a part the
mapper is given, never one it makes (a replay gives it ``navd.offline``'s fine refinement;
the daemon gives none, and reports each match as it is)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Protocol

import numpy as np
import numpy.typing as npt

from navd.geometry import Pose2
from navd.slam.keyframe import Keyframe
from navd.slam.settings import MapperSettings

__all__ = ["PoseRefiner"]


class PoseRefiner(Protocol):
    """Refines matched poses on the keyframes it was shown (tracking, the map and the loop
    closures go on from the match itself)."""

    def configure(self, settings: MapperSettings) -> None:
        """Take the mapper's new settings."""

    def add(self, keyframes: Sequence[Keyframe]) -> None:
        """The newest of ``keyframes`` was just made."""

    def clear(self) -> None:
        """Every keyframe shown so far moved or was replaced (a re-solve, a rebuild, a
        load)."""

    def refine(
        self, keyframes: Sequence[Keyframe], points: npt.NDArray[np.float64], pose: Pose2
    ) -> Pose2:
        """``pose`` (a scan's match; ``points`` the scan, robot frame, N x 2 [m]) refined."""
        ...
