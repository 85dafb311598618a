"""Errors raised by navd.slam."""

from __future__ import annotations

from navd.errors import NavdError

__all__ = ["SlamError"]


class SlamError(NavdError):
    """Base of the errors raised by navd.slam."""
