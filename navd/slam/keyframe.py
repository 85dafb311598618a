"""A keyframe: a scan in the pose graph at the pose it was taken."""

from __future__ import annotations

from dataclasses import dataclass

from navd.geometry import Pose2, ScanPoints

__all__ = ["Keyframe"]


@dataclass(frozen=True, slots=True)
class Keyframe:
    """A scan in the pose graph, with the pose it was taken at.

    The scan is kept only with loop closure on (the map is rebuilt from keyframes after the
    pose graph moves them); otherwise a keyframe is its pose, and memory stays small.
    ``mapped`` is False for a scan that did not match the map (its pose is the odometry's):
    with loop closure on it still joins the graph, so a loop found while the robot is lost
    on a drifted map corrects it, but only matched scans make the map.
    """

    stamp: float
    pose: Pose2
    scan: ScanPoints | None
    mapped: bool = True
