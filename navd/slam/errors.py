"""Errors raised by navd.slam."""

from __future__ import annotations

from navd.errors import NavdError

__all__ = ["MapFileError", "SlamError"]


class SlamError(NavdError):
    """Base of the errors raised by navd.slam."""


class MapFileError(SlamError):
    """A map file is missing, malformed or inconsistent with its YAML."""
