"""Errors raised by navd.planning."""

from __future__ import annotations

from navd.errors import NavdError

__all__ = ["GoalRefusedError", "GoalUnreachableError", "PlanningError", "StartBlockedError"]


class PlanningError(NavdError):
    """Base of the errors raised by navd.planning."""


class GoalUnreachableError(PlanningError):
    """No route leads to the goal; ``reason`` says why: "off the map", "occupied", "no route"."""

    def __init__(self, message: str, reason: str) -> None:
        super().__init__(message)
        self.reason = reason


class StartBlockedError(PlanningError):
    """The robot's own cell is off the map or too close to an obstacle to plan from."""


class GoalRefusedError(PlanningError):
    """The goal cannot be planned for at all (too far away, too large an area to search):
    trying again will not help, so the goal fails at once."""
