"""Errors raised by navd.geometry (the robot's geometry, and raster files of the map frame)."""

from __future__ import annotations

from navd.errors import NavdError

__all__ = ["GeometryError", "RasterFileError", "UnknownMountError"]


class GeometryError(NavdError):
    """Base of the errors raised by navd.geometry."""


class RasterFileError(GeometryError, ValueError):
    """A raster's YAML or image is missing or malformed (the message names the file)."""


class UnknownMountError(GeometryError, KeyError):
    """A device the mounts do not list (the message names the table to add it to)."""

    def __str__(self) -> str:  # a KeyError would print its message quoted
        return str(self.args[0]) if self.args else ""
