"""Errors raised by navd.sim."""

from __future__ import annotations

from navd.errors import NavdError

__all__ = ["SimError", "WorldError"]


class SimError(NavdError):
    """Base of the errors raised by navd.sim."""


class WorldError(SimError):
    """A world file or shape list is missing or malformed; the message names the key."""
