"""Manual driving: an operator's velocity commands take the wheel from the navigator.

Plain state with the time passed in. Each operator command is capped to the teleop limits
and starts (or extends) manual mode, which lasts ``resume_after_s`` past the last command;
the planner does not step its navigator meanwhile and resumes the goal afterwards. Stopping
when the operator goes quiet is not done here but by the chassis (a command older than
``safety.reaction_timeout_s`` is never executed), so the deadman holds whatever this state
thinks.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = ["ManualDriving", "ManualSettings"]


@dataclass(frozen=True, slots=True)
class ManualSettings:
    """The teleop section's values.

    Attributes:
        enabled: operators may drive.
        max_linear_mps: [m/s] top manual speed either way.
        max_angular_radps: [rad/s] top manual yaw rate.
        resume_after_s: [s] manual mode ends this long after the last command.
    """

    enabled: bool
    max_linear_mps: float
    max_angular_radps: float
    resume_after_s: float


def _cap(value: float, limit: float) -> float:
    return min(max(value, -limit), limit)


class ManualDriving:
    """Whether an operator drives, who, and until when."""

    def __init__(self) -> None:
        self.operator = ""  # who drives now ("" in auto)
        self._until = -math.inf  # [s] daemon time manual mode ends

    @property
    def active(self) -> bool:
        """True from an operator's first command until ``end`` is called."""
        return bool(self.operator)

    def command(
        self,
        settings: ManualSettings,
        operator: str,
        linear_mps: float,
        angular_radps: float,
        now: float,
    ) -> tuple[float, float, bool]:
        """Take an operator's command at ``now`` [s].

        Returns:
            The command capped to the teleop limits [m/s, rad/s], and whether it started
            manual mode (the navigator must pause).
        """
        started = not self.active
        self.operator = operator
        self._until = now + settings.resume_after_s
        linear = _cap(linear_mps, settings.max_linear_mps)
        angular = _cap(angular_radps, settings.max_angular_radps)
        return linear, angular, started

    def over(self, now: float) -> bool:
        """True when manual mode is on but its time is up at ``now`` [s]."""
        return self.active and now >= self._until

    def end(self) -> str:
        """Leave manual mode; returns the operator who drove."""
        operator, self.operator = self.operator, ""
        self._until = -math.inf
        return operator
