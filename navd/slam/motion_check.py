"""Whether a step between two scans is one the robot could physically make.

A tracker that follows an odometry spike (an encoder glitch: 1 m or 80° in a fifth of a
second), or takes a match that jumps the robot across a corridor, puts that jump in the map
and in every pose after it. ``MotionLimits`` says what is plausible; ``MotionCheck`` keeps the
tracker's last pose and step to judge the next against, and to coast on when the odometry
spikes (the last step again, as a robot's motion changes little in a scan period).

Logs stamp scans in bursts (intel: steps of 0.4 m 1 ms apart, after a pause), so a step's
time is taken as at least the scan period (the median time between the last ``PERIOD_SCANS``
scans) and at least ``MIN_STEP_S``: the check is for jumps, not for exact speeds. (With
0.2 s alone, intel with every other scan dropped was taken for jumps: 0.71 m against 0.029 m.)
"""

from __future__ import annotations

import collections
import math
import statistics
from collections.abc import Sequence
from dataclasses import dataclass

from navd.geometry import Pose2, wrap_angle

__all__ = ["MIN_STEP_S", "Jump", "MotionCheck", "MotionLimits", "jumps"]

MIN_STEP_S = 0.2  # [s] the least time a step between two scans is taken to have had
PERIOD_SCANS = 25  # the scan period is the median time between this many last scans
JUMP_FACTOR = 2.0  # a match is refused as a jump beyond this many times the limits


@dataclass(frozen=True, slots=True)
class MotionLimits:
    """The fastest a robot really moves: ``speed_mps`` [m/s] and ``turn_radps`` [rad/s]."""

    speed_mps: float
    turn_radps: float

    def allows(self, step: Pose2, dt_s: float) -> bool:
        """Whether ``step`` (in the frame of its start) fits in ``dt_s`` [s] (at least
        MIN_STEP_S; a caller passes at least the scan period)."""
        t = max(dt_s, MIN_STEP_S)
        return (
            math.hypot(step.x, step.y) <= self.speed_mps * t
            and abs(wrap_angle(step.yaw)) <= self.turn_radps * t
        )


@dataclass(frozen=True, slots=True)
class Jump:
    """A step between consecutive poses beyond the limits: the later pose's ``index`` and
    ``offset_s`` [s] from the first stamp, and its length ``distance_m`` and ``turn_deg``."""

    index: int
    offset_s: float
    distance_m: float
    turn_deg: float

    def as_dict(self) -> dict[str, float | int]:
        return {
            "index": self.index,
            "offset_s": round(self.offset_s, 3),
            "distance_m": round(self.distance_m, 3),
            "turn_deg": round(self.turn_deg, 1),
        }


def jumps(stamps: Sequence[float], poses: Sequence[Pose2], limits: MotionLimits) -> list[Jump]:
    """Every step of a trajectory (stamps ascending) beyond ``limits``, each step's time
    taken as at least the scan period, as the tracker takes it."""
    out = []
    period = ScanPeriod()
    for i in range(1, len(poses)):
        step = poses[i - 1].between(poses[i])
        dt = stamps[i] - stamps[i - 1]
        period.add(dt)
        if not limits.allows(step, max(dt, period.seconds)):
            out.append(
                Jump(
                    i,
                    stamps[i] - stamps[0],
                    math.hypot(step.x, step.y),
                    math.degrees(wrap_angle(step.yaw)),
                )
            )
    return out


class ScanPeriod:
    """The median time [s] between the last PERIOD_SCANS scans (0 before any)."""

    def __init__(self) -> None:
        self._gaps: collections.deque[float] = collections.deque(maxlen=PERIOD_SCANS)
        self.seconds = 0.0

    def add(self, dt_s: float) -> None:
        """The time from the last scan to this one."""
        self._gaps.append(dt_s)
        self.seconds = statistics.median(self._gaps)

    def clear(self) -> None:
        self._gaps.clear()
        self.seconds = 0.0


class MotionCheck:
    """The tracker's judge of steps: the last tracked pose and stamp, and the step to it.

    Args:
        limits: what is plausible.
    """

    def __init__(self, limits: MotionLimits) -> None:
        self.limits = limits
        self._last: tuple[float, Pose2] | None = None  # (stamp [s], pose)
        self._period = ScanPeriod()
        self._step = Pose2(0.0, 0.0, 0.0)  # the last step, in the frame of its start

    def forget(self) -> None:
        """Judge nothing until the next pose is recorded (a pose set from outside: the
        robot may have been carried there)."""
        self._last = None
        self._step = Pose2(0.0, 0.0, 0.0)

    def plausible(self, stamp: float, pose: Pose2) -> bool:
        """Whether the robot could be at ``pose`` at ``stamp`` [s] from the last pose."""
        if self._last is None:
            return True
        then, where = self._last
        return self.limits.allows(where.between(pose), max(stamp - then, self._period.seconds))

    def jumped(self, stamp: float, prior: Pose2, pose: Pose2) -> bool:
        """Whether ``pose`` (a match) is a clear jump from the last pose, beyond JUMP_FACTOR
        times the limits, where its ``prior`` was plausible (a prior that jumps itself was
        chosen so: the odometry said so, and the scan). Only the repair's wider search
        reaches that far from a plausible prior; refusing matches just beyond the limits
        cost more than it saved (intel with range noise: 0.086 m against 0.037 m)."""
        if self._last is None or not self.plausible(stamp, prior):
            return False
        then, where = self._last
        clear = MotionLimits(
            JUMP_FACTOR * self.limits.speed_mps, JUMP_FACTOR * self.limits.turn_radps
        )
        return not clear.allows(where.between(pose), max(stamp - then, self._period.seconds))

    def coasted(self) -> Pose2 | None:
        """The last pose moved by the last step again (None before any pose)."""
        return None if self._last is None else self._last[1].compose(self._step)

    def moved_to(self, pose: Pose2) -> None:
        """The last pose as the pose graph now places it (a loop closure moved the robot
        with its newest keyframe: no step of the robot's)."""
        if self._last is not None:
            self._last = (self._last[0], pose)

    def record(self, stamp: float, pose: Pose2) -> None:
        """The tracked pose at ``stamp`` [s]."""
        if self._last is not None:
            self._step = self._last[1].between(pose)
            self._period.add(stamp - self._last[0])
        self._last = (stamp, pose)
