"""TI INA219 on I2C: a battery's voltage and current through a shunt, and its charge from
the voltage (``navd sensor ina219``).

Written from TI's INA219 datasheet (SBOS448). Set-up: reset (CONFIG 0x00 = 0x8000), then
CONFIG = 0x399F, the power-on default, read back as the identity check (the chip has no
identity register): a 32 V bus range, the shunt's ±320 mV range, 12-bit conversions, shunt and
bus measured continuously. Each poll reads, big-endian: SHUNT 0x01, signed, 10 µV a count;
BUS 0x02, bits 15-3 at 4 mV a count (bit 0 flags a math overflow). The current is the shunt
voltage over the shunt's resistance (``--shunt-ohms``), taken as discharging while it flows
from IN+ to IN- (the chip between the battery and the load; ``--current-sign -1`` when wired
the other way round), so negative while discharging, as ROS has it; charging while it is
positive beyond ``CHARGING_A``.

The charge is read off the battery's resting voltage per cell (``--cells``,
``--chemistry``: a table of the voltage at each charge for Li-ion, LiFePO4 and lead-acid),
the voltage smoothed over ``SMOOTHING_S`` (the voltage sags under load and recovers at rest;
an estimate, not a fuel gauge: a battery's own gauge, sent by an MCU, is better).
"""

from __future__ import annotations

import math

import numpy as np

from navd.sensors.errors import ChipError
from navd.sensors.i2c import I2cBus, int16_be
from navd.wire import BatteryFrame, SensorFrame

__all__ = ["CHEMISTRIES", "INA219_ADDRESS", "Ina219", "charge_of"]

INA219_ADDRESS = 0x40
CONFIG, SHUNT, BUS = 0x00, 0x01, 0x02
RESET, DEFAULT_CONFIG = 0x8000, 0x399F
SHUNT_V_PER_COUNT = 10e-6
BUS_V_PER_COUNT = 4e-3
CHARGING_A = 0.05
SMOOTHING_S = 10.0
# [V per cell] resting voltage at 0, 10, ..., 100 % charge
CHEMISTRIES = {
    "li-ion": (3.0, 3.45, 3.6, 3.68, 3.74, 3.79, 3.85, 3.92, 4.0, 4.08, 4.2),
    "lifepo4": (2.5, 3.0, 3.15, 3.2, 3.22, 3.25, 3.27, 3.29, 3.3, 3.32, 3.4),
    "lead-acid": (1.75, 1.88, 1.93, 1.96, 1.99, 2.01, 2.03, 2.05, 2.08, 2.1, 2.13),
}


def charge_of(voltage_v: float, cells: int, chemistry: str) -> float:
    """[0, 1] the charge a battery of ``cells`` cells at rest at ``voltage_v`` has."""
    table = CHEMISTRIES[chemistry]
    return float(np.interp(voltage_v / cells, table, np.linspace(0.0, 1.0, len(table))))


class Ina219:
    """An INA219 on ``bus`` at ``address``, measuring a battery of ``cells`` cells.

    Args:
        rate_hz: [Hz] polls per second.
        shunt_ohms: [Ω] the shunt resistor (0.1 on most breakout boards).
        current_sign: 1, or -1 when the chip is wired the other way round.
    """

    def __init__(
        self,
        bus: I2cBus,
        address: int = INA219_ADDRESS,
        rate_hz: float = 2.0,
        *,
        shunt_ohms: float = 0.1,
        cells: int = 3,
        chemistry: str = "li-ion",
        current_sign: int = 1,
    ) -> None:
        if chemistry not in CHEMISTRIES:
            raise ChipError(f"chemistry {chemistry!r}: one of {', '.join(CHEMISTRIES)}")
        self.bus, self.address = bus, address
        self.rate_hz = min(max(rate_hz, 0.1), 50.0)
        self.shunt_ohms, self.cells, self.chemistry = shunt_ohms, cells, chemistry
        self.current_sign = current_sign
        self.overflows = 0
        self._smoothed_v: float | None = None

    def setup(self) -> None:
        address = self.address
        self._write(CONFIG, RESET)
        self._write(CONFIG, DEFAULT_CONFIG)
        config = self._read(CONFIG)
        if config != DEFAULT_CONFIG:
            raise ChipError(
                f"CONFIG at 0x{address:02X} reads 0x{config:04X} after it was set to "
                f"0x{DEFAULT_CONFIG:04X}: not an INA219; check --address (0x40 to 0x4F)"
            )

    def poll(self, stamp: float) -> list[SensorFrame]:
        raw_bus = self._read(BUS)
        if raw_bus & 0x01:
            self.overflows += 1  # the current or power would not fit: this reading is void
            return []
        shunt = self._read(SHUNT)
        shunt_v = int16_be(shunt >> 8, shunt & 0xFF) * SHUNT_V_PER_COUNT
        load_v = (raw_bus >> 3) * BUS_V_PER_COUNT
        battery_v = load_v + shunt_v  # the bus is measured on the load's side of the shunt
        current = -self.current_sign * shunt_v / self.shunt_ohms  # discharging: negative
        weight = min(1.0, 1.0 / (self.rate_hz * SMOOTHING_S))
        smoothed = self._smoothed_v
        smoothed = battery_v if smoothed is None else smoothed + weight * (battery_v - smoothed)
        self._smoothed_v = smoothed
        charge = charge_of(smoothed, self.cells, self.chemistry)
        if not math.isfinite(charge):
            return []
        return [
            BatteryFrame(
                stamp=stamp,
                voltage=round(battery_v, 3),
                current=round(current, 4),
                percentage=round(charge, 4),
                charging=current > CHARGING_A,
            )
        ]

    def counts(self) -> dict[str, int]:
        return {"overflows": self.overflows}

    def _read(self, register: int) -> int:
        high, low = self.bus.read_i2c_block_data(self.address, register, 2)
        return (high << 8) | low

    def _write(self, register: int, value: int) -> None:
        """A 16-bit register, big-endian: the register pointer, then its two bytes."""
        self.bus.write_i2c_block_data(self.address, register, [value >> 8, value & 0xFF])
