"""Errors raised by navd.estimation."""

from __future__ import annotations

from navd.errors import NavdError

__all__ = ["EstimationError", "GeoError"]


class EstimationError(NavdError):
    """Base of the errors raised by navd.estimation."""


class GeoError(EstimationError):
    """A WGS84 position cannot be placed in the map frame (outside UTM, or off the map)."""
