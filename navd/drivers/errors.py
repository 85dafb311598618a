"""Errors raised by navd.drivers."""

from __future__ import annotations

from navd.errors import NavdError

__all__ = ["DriverError", "SerialPortError", "WireError"]


class DriverError(NavdError):
    """Base of the errors raised by navd.drivers."""


class WireError(DriverError):
    """A client sent a frame the protocol does not allow.

    Args:
        field: the offending field's path ("ranges.3"), or "" for the frame as a whole.
        reason: what is wrong and what is expected.
    """

    def __init__(self, field: str, reason: str) -> None:
        super().__init__(f"{field}: {reason}" if field else reason)
        self.field = field
        self.reason = reason


class SerialPortError(DriverError):
    """The chassis serial port could not be opened or was lost."""
