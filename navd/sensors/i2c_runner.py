"""An I2C sensor program's loop: a chip on an I2C bus on one side, navd on the other.

Like the serial programs (``runner``): the bus and navd are each (re)opened with backoff, a
chip that stops answering is set up again, and every kind of trouble is logged once when it
starts and once when it ends. The chip is polled at its rate on a fixed schedule (a late
poll does not shift the ones after it). A chip whose frames go to two roles (the BNO055: an
IMU and a compass) has a connection for each: the compass's id is the device id with
``-heading`` after it.
"""

from __future__ import annotations

import contextlib
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass

from navd.sensors.bno055 import Bno055
from navd.sensors.connections import role_of
from navd.sensors.errors import ChipError
from navd.sensors.i2c import Chip, I2cBus
from navd.sensors.ina219 import Ina219
from navd.sensors.link import Link
from navd.sensors.magnetometer import CompassCalibration, Hmc5883l, Qmc5883l
from navd.sensors.mpu import Mpu
from navd.sensors.runner import (
    BACKOFF_S,
    MAX_BACKOFF_S,
    SUMMARY_PERIOD_S,
    Trouble,
    drain_replies,
)
from navd.wire import Client, ClientError, Role

__all__ = ["I2C_KINDS", "I2cOptions", "make_chip", "open_smbus", "run_i2c_sensor"]

# Each I2C kind's roles: the first goes under the device id, a second under ``ID-heading``.
I2C_KINDS: dict[str, tuple[Role, ...]] = {
    "mpu6050": ("imu",),
    "mpu9250": ("imu",),
    "bno055": ("imu", "compass"),
    "qmc5883l": ("compass",),
    "hmc5883l": ("compass",),
    "ina219": ("battery",),
}


@dataclass(frozen=True, slots=True)
class I2cOptions:
    """How a chip is read.

    Attributes:
        address: its I2C address (None: the chip's usual one).
        rate_hz: [Hz] polls per second (None: the chip's usual rate).
        calibration: a magnetometer's correction.
        battery: a battery monitor's shunt [Ω], cells, chemistry and current sign.
    """

    address: int | None = None
    rate_hz: float | None = None
    calibration: CompassCalibration | None = None
    battery: tuple[float, int, str, int] = (0.1, 3, "li-ion", 1)


def make_chip(kind: str, bus: I2cBus, options: I2cOptions) -> Chip:
    """The driver of ``kind`` on ``bus``."""
    extra: dict[str, object] = {}
    if options.address is not None:
        extra["address"] = options.address
    if options.rate_hz is not None:
        extra["rate_hz"] = options.rate_hz
    if kind in ("mpu6050", "mpu9250"):
        return Mpu(bus, kind, **extra)  # type: ignore[arg-type]
    if kind == "bno055":
        return Bno055(bus, **extra)  # type: ignore[arg-type]
    if kind == "ina219":
        shunt, cells, chemistry, sign = options.battery
        return Ina219(bus, shunt_ohms=shunt, cells=cells, chemistry=chemistry,
                      current_sign=sign, **extra)  # type: ignore[arg-type]  # fmt: skip
    magnetometer = Qmc5883l if kind == "qmc5883l" else Hmc5883l
    return magnetometer(bus, options.calibration, **extra)  # type: ignore[arg-type]


def open_smbus(path: str) -> I2cBus:
    """The I2C bus at ``path`` (/dev/i2c-N), through smbus2."""
    from smbus2 import SMBus  # noqa: PLC0415 - only I2C programs need it

    bus: I2cBus = SMBus(path)
    return bus


def run_i2c_sensor(
    kind: str,
    link: Link,
    options: I2cOptions,
    stop: threading.Event | None = None,
    *,
    open_bus: Callable[[str], I2cBus] = open_smbus,
) -> None:
    """Read the chip on bus ``link.port`` and stream to navd until ``stop`` is set."""
    program = _I2cProgram(kind, link, options, stop or threading.Event(), open_bus)
    try:
        program.run()
    finally:
        program.close()
        program._close_bus()


class _I2cProgram:
    """One I2C sensor program's state: its chip, its connections to navd."""

    def __init__(
        self,
        kind: str,
        link: Link,
        options: I2cOptions,
        stop: threading.Event,
        open_bus: Callable[[str], I2cBus],
    ) -> None:
        self.kind, self.link, self.options, self.stop = kind, link, options, stop
        self.open_bus = open_bus
        self.trouble = Trouble()
        roles = I2C_KINDS[kind]
        self.main_role = roles[0]
        self.ids = {
            role: link.device_id if i == 0 else f"{link.device_id}-heading"
            for i, role in enumerate(roles)
        }
        self.navd = f"{link.host}:{link.navd_port}"
        self.chip: Chip | None = None
        self.bus: I2cBus | None = None
        self.clients: dict[Role, Client] = {}
        self.logged: dict[str, int] = {}

    def run(self) -> None:
        link, trouble = self.link, self.trouble
        trouble.log.info(
            "sensor_started", kind=self.kind, bus=link.port, device_ids=list(self.ids.values())
        )
        backoff = BACKOFF_S
        summary_at = time.monotonic()
        while not self.stop.is_set():
            if self.chip is None:
                self.chip = self._set_up()
            if self.chip is not None and len(self.clients) < len(self.ids):
                self.clients = self._connect()
            if self.chip is None or len(self.clients) < len(self.ids):
                self.stop.wait(backoff)
                backoff = min(backoff * 2, MAX_BACKOFF_S)
                continue
            backoff = BACKOFF_S
            self._stream(self.chip)
            counts = {} if self.chip is None else self.chip.counts()
            for name, count in counts.items():
                if count and not self.logged.get(name):
                    trouble.log.warning("bad_input", counter=name, count=count)
                self.logged[name] = count
            if time.monotonic() - summary_at >= SUMMARY_PERIOD_S:
                summary_at = time.monotonic()
                trouble.log.info("sensor_counts", **counts)

    def close(self) -> None:
        for client in self.clients.values():
            client.close()
        self.clients = {}

    def _close_bus(self) -> None:
        """Close the bus's file (one is opened for each set-up)."""
        bus, self.bus = self.bus, None
        close = getattr(bus, "close", None)
        if close is not None:
            with contextlib.suppress(OSError):
                close()

    def _set_up(self) -> Chip | None:
        bus, trouble = self.link.port, self.trouble
        self._close_bus()
        try:
            self.bus = self.open_bus(bus)
            chip = make_chip(self.kind, self.bus, self.options)
            chip.setup()
        except ChipError as err:
            self._close_bus()
            trouble.begin("wrong_chip", bus=bus, error=str(err))
            return None
        except OSError as err:
            self._close_bus()
            trouble.begin("device_unavailable", bus=bus, error=str(err))
            return None
        for kind in ("device_unavailable", "device_lost", "wrong_chip"):
            trouble.end(kind, "device_opened", bus=bus)
        return chip

    def _connect(self) -> dict[Role, Client]:
        link, clients = self.link, {}
        try:
            for role, device_id in self.ids.items():
                clients[role] = Client(
                    link.host, link.navd_port, role=role, device_id=device_id, token=link.token
                )
        except ClientError as err:
            for client in clients.values():
                client.close()
            self.trouble.begin("navd_unreachable", navd=self.navd, error=str(err))
            return {}
        self.trouble.end("navd_unreachable", "navd_connected", navd=self.navd)
        self.trouble.end("navd_lost", "navd_connected", navd=self.navd)
        return clients

    def _stream(self, chip: Chip) -> None:
        """Poll for about a second on a fixed schedule."""
        period_s = 1.0 / chip.rate_hz
        due = time.monotonic()
        end = due + 1.0
        while due < end and not self.stop.is_set():
            self.stop.wait(max(due - time.monotonic(), 0.0))
            due += period_s
            now = time.monotonic()
            try:
                frames = chip.poll(now)
            except OSError as err:
                self.trouble.begin("device_lost", bus=self.link.port, error=str(err))
                self.chip = None  # set up again: a chip that lost power forgets its set-up
                return
            try:
                for frame in frames:
                    self.clients[role_of(frame, self.main_role)].send(frame)
                for client in self.clients.values():
                    drain_replies(client, self.trouble)
            except OSError as err:
                self.trouble.begin("navd_lost", navd=self.navd, error=str(err))
                self.close()
                return
            if now - due > 1.0:
                due = now  # a long stall (the machine suspended): start the schedule afresh
