"""Stuck handling (seed 001 §4.5): no progress raises the minimum speed, then forces reversing."""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import StrEnum

from navd.config import NavdConfig

__all__ = ["StuckMonitor", "StuckPhase", "StuckState"]


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


class StuckMonitor:
    """Watches progress: moving ``min_progress_m`` or turning ``rotation_tolerance_rad`` from
    the reference pose resets it. Once it forces backward motion it holds that until the
    robot has backed up ``backup_distance_m`` (then BACKED_OUT, once), so the robot cannot
    creep back and forth in front of a dead end forever.

    Args:
        config: the planning and robot sections give the times, tolerances and speeds.
    """

    def __init__(self, config: NavdConfig) -> None:
        planning = config.planning
        self.stuck_time_s = planning.stuck_time_s
        self.backward_time_s = planning.stuck_time_force_backward_s
        self.max_stuck_time_s = planning.max_stuck_time_s
        self.min_progress_m = planning.stuck_min_progress_m
        self.rotation_tolerance_rad = planning.stuck_rotation_tolerance_rad
        self.min_speed_mps = planning.min_linear_speed_mps
        self.max_speed_mps = config.robot.max_linear_speed_mps
        self.backup_distance_m = planning.backup_distance_m
        self._reference: tuple[float, float, float, float] | None = None
        self._backing_from: tuple[float, float] | None = None

    def reset(self) -> None:
        """Forget the reference: the next update starts a fresh watch."""
        self._reference = None
        self._backing_from = None

    def update(self, now: float, x_m: float, y_m: float, yaw_rad: float) -> StuckState:
        """Take the robot's pose at ``now`` [s]; return how stuck it is."""
        if self._reference is None:
            self._reference = (now, x_m, y_m, yaw_rad)
        since, rx, ry, ryaw = self._reference
        if self._backing_from is not None:
            # Once forced backwards, keep going until backed up the whole distance.
            bx, by = self._backing_from
            if math.hypot(x_m - bx, y_m - by) >= self.backup_distance_m:
                self.reset()
                return StuckState(StuckPhase.BACKED_OUT, now - since, 0.0)
            if now - since > self.max_stuck_time_s:
                return StuckState(StuckPhase.STUCK, now - since, 0.0)
            return StuckState(StuckPhase.BACKING, now - since, self.min_speed_mps)
        turned = abs((yaw_rad - ryaw + math.pi) % (2.0 * math.pi) - math.pi)
        if math.hypot(x_m - rx, y_m - ry) > self.min_progress_m or (
            turned > self.rotation_tolerance_rad
        ):
            self._reference = (now, x_m, y_m, yaw_rad)
            since = now
        stuck_s = now - since
        if stuck_s < self.stuck_time_s:
            return StuckState(StuckPhase.MOVING, stuck_s, 0.0)
        if stuck_s > self.max_stuck_time_s:
            return StuckState(StuckPhase.STUCK, stuck_s, 0.0)
        # The seed's rising minimum: from min speed at 0 s to top speed at max_stuck_time.
        rising = self.min_speed_mps + (self.max_speed_mps - self.min_speed_mps) * (
            stuck_s / self.max_stuck_time_s
        )
        if stuck_s > self.backward_time_s:
            self._backing_from = (x_m, y_m)
            return StuckState(StuckPhase.BACKING, stuck_s, self.min_speed_mps)
        return StuckState(StuckPhase.PUSHING, stuck_s, rising)
