"""Errors raised by navd.estimation."""

from __future__ import annotations

from navd.errors import NavdError

__all__ = ["EstimationError"]


class EstimationError(NavdError):
    """Base of the errors raised by navd.estimation."""
