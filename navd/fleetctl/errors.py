"""Errors raised by navd.fleetctl (``navd fleet``)."""

from __future__ import annotations

from navd.errors import NavdError

__all__ = ["FleetControlError", "GroupGoalError"]


class FleetControlError(NavdError, ValueError):
    """Base of the errors raised by navd.fleetctl: what cannot be asked of the fleet, named."""


class GroupGoalError(FleetControlError):
    """A group goal that cannot be driven: no robots, robots on different maps or not
    online, a formation that does not fit, no way for the group's centre."""
