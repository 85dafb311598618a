"""Errors raised by navd.drivers."""

from __future__ import annotations

from navd.errors import NavdError

__all__ = ["DriverError", "SerialPortError"]


class DriverError(NavdError):
    """Base of the errors raised by navd.drivers."""


class SerialPortError(DriverError):
    """The chassis serial port could not be opened or was lost."""
