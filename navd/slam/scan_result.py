"""What the mapper says of each scan (``ScanResult``) and of all of them so far
(``TrackingCounts``: matched, weak, exploring, doubtful, repaired, lost, keyframes)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from navd.geometry import Pose2
from navd.slam.loop_closure import LoopCounts

__all__ = ["ScanResult", "TrackingCounts"]

FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True, slots=True)
class ScanResult:
    """Where a scan was taken.

    Attributes:
        pose: the robot's pose in the map.
        covariance: 3x3 covariance of (x, y, yaw) from the match (the prior's, if unmatched).
        score: mean likelihood under the matched points, in [0, 1] (0: not matched).
        matched: True if scan matching set the pose.
        keyframe: True if the scan was inserted into the map.
    """

    pose: Pose2
    covariance: FloatArray
    score: float
    matched: bool
    keyframe: bool


@dataclass
class TrackingCounts:
    """What tracking did with the scans so far (each a count)."""

    scans: int = 0
    matched: int = 0
    weak_matches: int = 0
    exploring: int = 0
    keyframes: int = 0
    fields_built: int = 0
    optimizations: int = 0
    repaired: int = 0
    repair_ambiguous: int = 0
    doubtful: int = 0
    lost: int = 0
    odometry_spikes: int = 0  # odometry steps no robot makes, not followed
    implausible: int = 0  # matches that implied such a step, refused

    def as_dict(self, loops: LoopCounts, heading_weight_per_rad2: float) -> dict[str, int | float]:
        """The counts with loop closure's (``loops``) and the heading prior's weight in use:
        the replay summary's and the daemon status's."""
        c = self
        return {
            "scans": c.scans,
            "matched": c.matched,
            "weak_matches": c.weak_matches,
            "exploring": c.exploring,
            "doubtful": c.doubtful,
            "repaired": c.repaired,
            "repair_ambiguous": c.repair_ambiguous,
            "lost": c.lost,
            "odometry_spikes": c.odometry_spikes,
            "implausible_matches": c.implausible,
            "keyframes": c.keyframes,
            "loop_checks": loops.checks,
            "loops_found": loops.found,
            "loops_ambiguous": loops.ambiguous,
            "loops_far_held": loops.far_held,
            "loops_far_confirmed": loops.far_confirmed,
            "graph_optimizations": c.optimizations,
            "heading_prior_weight_per_rad2": round(heading_weight_per_rad2, 3),
        }
