"""Errors raised by navd.drivers."""

from __future__ import annotations

from navd.errors import NavdError

__all__ = ["DriverError"]


class DriverError(NavdError):
    """Base of the errors raised by navd.drivers."""
