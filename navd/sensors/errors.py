"""Errors raised by navd.sensors (the ``navd sensor`` programs and their devices)."""

from __future__ import annotations

from navd.errors import NavdError

__all__ = ["CalibrationError", "ChipError", "SensorError"]


class SensorError(NavdError):
    """Base of the errors raised by navd.sensors."""


class ChipError(SensorError):
    """The chip at the address is not the one asked for, or refused its set-up."""


class CalibrationError(SensorError, ValueError):
    """Samples that cannot calibrate a magnetometer (the message says what to do)."""
