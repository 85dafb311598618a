"""I2C chips as navd sensors: the bus they are read through, and what every chip driver does.

A chip driver checks the chip's identity register, configures it, and is then polled at its
output rate; each poll gives zero or more frames (an IMU sample, a compass heading). The bus
is anything with smbus2's register calls, so the drivers are tested against register-level
fakes of the chips.
"""

from __future__ import annotations

from typing import Protocol

from navd.sensors.errors import ChipError
from navd.wire import SensorFrame

__all__ = ["Chip", "ChipError", "I2cBus", "int16_be", "int16_le"]


class I2cBus(Protocol):
    """The register calls of ``smbus2.SMBus`` a driver uses."""

    def read_byte_data(self, i2c_addr: int, register: int) -> int: ...

    def write_byte_data(self, i2c_addr: int, register: int, value: int) -> None: ...

    def read_i2c_block_data(self, i2c_addr: int, register: int, length: int) -> list[int]: ...

    def write_i2c_block_data(self, i2c_addr: int, register: int, data: list[int]) -> None: ...


class Chip(Protocol):
    """A chip driver (see the module docstring).

    Attributes:
        rate_hz: [Hz] how often ``poll`` is called.
    """

    rate_hz: float

    def setup(self) -> None:
        """Check the identity register and configure the chip.

        Raises:
            ChipError: another chip (or none) answers at the address.
            OSError: the bus did not answer.
        """
        ...

    def poll(self, stamp: float) -> list[SensorFrame]:
        """Read the chip; the frames of the data it had ready at ``stamp`` [s].

        Raises:
            OSError: the bus did not answer.
        """
        ...

    def counts(self) -> dict[str, int]:
        """Counters of bad input (overflows, samples not ready)."""
        ...


def int16_be(high: int, low: int) -> int:
    """A signed 16-bit value from its big-endian bytes."""
    value = (high << 8) | low
    return value - 0x10000 if value & 0x8000 else value


def int16_le(low: int, high: int) -> int:
    """A signed 16-bit value from its little-endian bytes."""
    return int16_be(high, low)
