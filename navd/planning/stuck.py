"""Stuck handling (seed 001 §4.5): no progress raises the minimum speed, then forces reversing."""

from __future__ import annotations

from dataclasses import dataclass
from enum import StrEnum

from navd.geometry import Pose2, angle_between

__all__ = ["StuckMonitor", "StuckPhase", "StuckSettings", "StuckState"]


class StuckPhase(StrEnum):
    """How stuck the robot is."""

    MOVING = "moving"  # progress within stuck_time
    PUSHING = "pushing"  # stuck: the minimum speed rises with the time stuck
    BACKING = "backing"  # stuck past stuck_time_force_backward: drive backwards
    BACKED_OUT = "backed_out"  # backed up backup_distance_m: replan from here (once)
    STUCK = "stuck"  # past max_stuck_time: report StuckDetected


@dataclass(frozen=True, slots=True)
class StuckState:
    """The monitor's verdict.

    Attributes:
        phase: see StuckPhase.
        stuck_s: [s] time since the last progress.
        min_speed_mps: [m/s] the slowest |v| the local planner may choose now (0: any).
    """

    phase: StuckPhase
    stuck_s: float
    min_speed_mps: float


@dataclass(frozen=True, slots=True)
class StuckSettings:
    """The stuck monitor's times, tolerances and speeds (planning and robot sections).

    Attributes:
        stuck_time_s: [s] this long without progress is stuck.
        backward_time_s: [s] stuck this long forces backward motion.
        max_stuck_time_s: [s] stuck this long is reported (StuckDetected).
        min_progress_m: [m] moving this far from the reference is progress.
        rotation_tolerance_rad: [rad] turning this far is progress too.
        min_speed_mps, max_speed_mps: [m/s] the rising minimum goes from one to the other.
        backup_distance_m: [m] a forced backward move goes this far.
    """

    stuck_time_s: float
    backward_time_s: float
    max_stuck_time_s: float
    min_progress_m: float
    rotation_tolerance_rad: float
    min_speed_mps: float
    max_speed_mps: float
    backup_distance_m: float


class StuckMonitor:
    """Watches progress: moving ``min_progress_m`` or turning ``rotation_tolerance_rad`` from
    the reference pose resets it. Once it forces backward motion it holds that until the
    robot has backed up ``backup_distance_m`` (then BACKED_OUT, once), so the robot cannot
    creep back and forth in front of a dead end forever.

    Args:
        settings: the times, tolerances and speeds; ``configure`` swaps them without
            forgetting how long the robot has been stuck.
    """

    def __init__(self, settings: StuckSettings) -> None:
        self.settings = settings
        self._reference: tuple[float, Pose2] | None = None  # (since [s], pose)
        self._backing_from: Pose2 | None = None

    def configure(self, settings: StuckSettings) -> None:
        """Take new settings; the watch in progress (its reference, backing) goes on."""
        self.settings = settings

    def reset(self) -> None:
        """Forget the reference: the next update starts a fresh watch."""
        self._reference = None
        self._backing_from = None

    def update(self, now: float, pose: Pose2) -> StuckState:
        """Take the robot's pose at ``now`` [s]; return how stuck it is."""
        s = self.settings
        if self._reference is None:
            self._reference = (now, pose)
        since, reference = self._reference
        if self._backing_from is not None:
            # Once forced backwards, keep going until backed up the whole distance.
            if self._backing_from.distance_to(pose) >= s.backup_distance_m:
                self.reset()
                return StuckState(StuckPhase.BACKED_OUT, now - since, 0.0)
            if now - since > s.max_stuck_time_s:
                return StuckState(StuckPhase.STUCK, now - since, 0.0)
            return StuckState(StuckPhase.BACKING, now - since, s.min_speed_mps)
        turned = angle_between(pose.yaw, reference.yaw)
        if reference.distance_to(pose) > s.min_progress_m or turned > s.rotation_tolerance_rad:
            self._reference = (now, pose)
            since = now
        stuck_s = now - since
        if stuck_s < s.stuck_time_s:
            return StuckState(StuckPhase.MOVING, stuck_s, 0.0)
        if stuck_s > s.max_stuck_time_s:
            return StuckState(StuckPhase.STUCK, stuck_s, 0.0)
        # The seed's rising minimum: from min speed at 0 s to top speed at max_stuck_time.
        rising = s.min_speed_mps + (s.max_speed_mps - s.min_speed_mps) * (
            stuck_s / s.max_stuck_time_s
        )
        if stuck_s > s.backward_time_s:
            self._backing_from = pose
            return StuckState(StuckPhase.BACKING, stuck_s, s.min_speed_mps)
        return StuckState(StuckPhase.PUSHING, stuck_s, rising)
