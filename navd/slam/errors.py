"""Errors raised by navd.slam."""

from __future__ import annotations

from navd.errors import NavdError

__all__ = ["LogFormatError", "MapFileError", "SlamError"]


class SlamError(NavdError):
    """Base of the errors raised by navd.slam."""


class LogFormatError(SlamError):
    """A log file cannot be read: the message names the file, the line and what was expected."""


class MapFileError(SlamError):
    """A map file is missing, malformed or inconsistent with its YAML."""
