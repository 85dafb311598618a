"""Errors raised by navd.offline (recorded logs, their replay and their evaluation)."""

from __future__ import annotations

from navd.errors import NavdError

__all__ = ["LogFormatError", "OfflineError"]


class OfflineError(NavdError):
    """Base of the errors raised by navd.offline."""


class LogFormatError(OfflineError):
    """A log file cannot be read: the message names the file, the line and what was expected."""
