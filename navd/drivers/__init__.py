"""Drivers: the TCP peripheral server (sensor and control clients) and the STM32 chassis."""

from navd.drivers.errors import DriverError

__all__ = ["DriverError"]
