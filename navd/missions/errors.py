"""Errors raised by navd.missions."""

from __future__ import annotations

from navd.errors import NavdError

__all__ = ["MissionError", "UnknownBeaconError"]


class MissionError(NavdError):
    """Base of the errors raised by navd.missions."""


class UnknownBeaconError(MissionError, LookupError):
    """A step names a beacon with no place yet (the message names the known ones)."""
