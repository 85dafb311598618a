"""Recording a magnetometer through a turn in place, for its hard- and soft-iron correction."""

from __future__ import annotations

import time
from collections.abc import Callable

from navd.sensors.i2c import I2cBus
from navd.sensors.i2c_runner import I2cOptions, make_chip, open_smbus
from navd.sensors.magnetometer import CompassCalibration, Magnetometer, fit_calibration

__all__ = ["record_turn"]


def record_turn(
    chip_kind: str,
    bus_path: str,
    options: I2cOptions,
    seconds: float,
    *,
    open_bus: Callable[[str], I2cBus] = open_smbus,
    clock: Callable[[], float] = time.monotonic,
    sleep: Callable[[float], None] = time.sleep,
) -> tuple[CompassCalibration, int]:
    """Read the magnetometer for ``seconds`` while a person turns the robot; the fitted
    calibration and how many samples it came from.

    Raises:
        ChipError: another chip answers at the address.
        OSError: the bus did not answer.
        ValueError: the samples do not cover a turn (see ``fit_calibration``).
    """
    chip = make_chip(chip_kind, open_bus(bus_path), options)
    assert isinstance(chip, Magnetometer)
    chip.setup()
    samples: list[tuple[float, float]] = []
    end = clock() + seconds
    while clock() < end:
        if chip.poll(clock()) and chip.last_ut is not None:
            samples.append((chip.last_ut[0], chip.last_ut[1]))
        sleep(1.0 / chip.rate_hz)
    return fit_calibration(samples), len(samples)
