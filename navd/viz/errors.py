"""Errors raised by navd.viz (the live view, viewers' commands, recordings)."""

from __future__ import annotations

from navd.errors import NavdError

__all__ = ["CommandRefusedError", "RecordCodecError", "RecordingError", "VizError"]


class VizError(NavdError):
    """Base of the errors raised by navd.viz."""


class CommandRefusedError(VizError):
    """A viewer's command that is not carried out; the message says why."""


class RecordCodecError(VizError):
    """A recorded message that cannot be read back; the message says which and why."""


class RecordingError(VizError):
    """A recording that cannot be read or replayed: the message names the file and why."""
