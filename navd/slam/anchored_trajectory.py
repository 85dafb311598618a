"""Every scan's pose, kept relative to the newest keyframe when the scan came, so that the
whole trajectory follows the keyframes when the pose graph moves them (a replay's output;
a robot running for days keeps none: it grows with every scan)."""

from __future__ import annotations

from collections.abc import Sequence

from navd.geometry import Pose2
from navd.slam.keyframe import Keyframe

__all__ = ["AnchoredTrajectory"]


class AnchoredTrajectory:
    """Scan poses anchored to keyframes (before the first keyframe: as they are)."""

    def __init__(self) -> None:
        self._anchors: list[tuple[int, Pose2]] = []  # (keyframe index or -1, relative pose)

    def clear(self) -> None:
        """Forget every pose (the keyframes they were anchored to were replaced)."""
        self._anchors = []

    def add(self, keyframes: Sequence[Keyframe], pose: Pose2) -> None:
        """Keep ``pose``, anchored to the newest of ``keyframes``."""
        index = len(keyframes) - 1
        if index < 0:
            self._anchors.append((-1, pose))
        else:
            self._anchors.append((index, keyframes[index].pose.between(pose)))

    def poses(self, keyframes: Sequence[Keyframe]) -> list[Pose2]:
        """Every pose kept, with the keyframes where they are now."""
        return [
            keyframes[index].pose.compose(relative) if index >= 0 else relative
            for index, relative in self._anchors
        ]
