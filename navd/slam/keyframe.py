"""A keyframe: a scan in the pose graph at the pose it was taken; and the edge that ties a
new one into the graph."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from navd.geometry import Pose2, ScanPoints
from navd.slam.pose_graph import Edge

__all__ = ["EDGE_WEIGHTS", "FOUND_WEIGHTS", "Keyframe", "edge_to_new"]

# Relative-pose uncertainty assumed for graph edges (tracking and loop closures alike).
EDGE_WEIGHTS = (1 / 0.05, 1 / 0.05, 1 / 0.0175)
# ... and for the edge from the nearest old keyframe to the first new one after a load or a
# pose set from outside (a global search's pose: a cell or two, a degree or two).
FOUND_WEIGHTS = (1 / 0.1, 1 / 0.1, 1 / 0.035)


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


def edge_to_new(keyframes: Sequence[Keyframe], pose: Pose2, *, found: bool) -> Edge:
    """The edge that ties a new keyframe at ``pose`` into the graph: from the last keyframe
    (the tracked step), or, when the pose was ``found`` (first after a load or a pose set
    from outside), from the nearest keyframe, as a found pose (looser, robust, like a loop)."""
    new = len(keyframes)
    if not found:
        return Edge(new - 1, new, keyframes[-1].pose.between(pose), EDGE_WEIGHTS)
    where = np.array([(f.pose.x, f.pose.y) for f in keyframes])
    near = int(np.argmin(np.hypot(where[:, 0] - pose.x, where[:, 1] - pose.y)))
    return Edge(near, new, keyframes[near].pose.between(pose), FOUND_WEIGHTS, True)
