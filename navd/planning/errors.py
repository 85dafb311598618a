"""Errors raised by navd.planning."""

from __future__ import annotations

from navd.errors import NavdError

__all__ = ["PlanningError"]


class PlanningError(NavdError):
    """Base of the errors raised by navd.planning."""
