"""I2C sensor programs against the real daemon on a real socket (the chips are register-level
fakes: no I2C bus here): samples and headings arrive with their values, a chip that stops
answering is set up again, and a compass calibration is written into the config file."""

from __future__ import annotations

import asyncio
import math
import threading
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from navd.config import ConfigError, load_config, set_table_keys
from navd.lifecycle.messages import CompassHeading, DeviceConnected, Imu
from navd.sensors.calibration import record_turn
from navd.sensors.i2c_runner import I2cOptions, run_i2c_sensor
from navd.sensors.link import Link
from tests.drivers.conftest import record, running_daemon, until
from tests.sensors.chip_fakes import (
    GRAVITY,
    FakeBno055,
    FakeBus,
    FakeHmc5883l,
    FakeMpu,
    FakeQmc5883l,
)


def _program(
    kind: str, bus: FakeBus, port: int, device_id: str
) -> tuple[threading.Thread, threading.Event]:
    stop = threading.Event()
    link = Link(port="/dev/i2c-1", baud=0, host="127.0.0.1", navd_port=port, device_id=device_id)
    thread = threading.Thread(
        target=run_i2c_sensor,
        args=(kind, link, I2cOptions(rate_hz=100.0), stop),
        kwargs={"open_bus": lambda path: bus},
        daemon=True,
    )
    thread.start()
    return thread, stop


async def test_an_mpu6050_streams_samples_and_survives_a_chip_that_stops_answering() -> None:
    chip = FakeMpu(who=0x68, gyro_dps=(0.0, 0.0, 45.0), accel_g=(0.1, 0.0, 1.0))
    bus = FakeBus(chip)
    async with running_daemon() as (daemon, port):
        samples = record(daemon, Imu)
        thread, stop = _program("mpu6050", bus, port, "imu0")
        try:
            await until(lambda: len(samples) >= 20, 10.0)
            last = samples[-1]
            assert last.device_id == "imu0"
            assert last.gyro_radps[2] == pytest.approx(math.radians(45.0), abs=1e-3)
            assert last.accel_mps2[0] == pytest.approx(0.1 * GRAVITY, abs=0.01)
            # the chip browns out: it stops answering and forgets its set-up
            bus.broken = True
            await asyncio.sleep(0.5)
            chip.regs[0x6B] = 0x40  # asleep again, as after power-on
            before = len(samples)
            bus.broken = False
            await until(lambda: len(samples) > before + 10, 10.0)
            assert samples[-1].gyro_radps[2] == pytest.approx(math.radians(45.0), abs=1e-3)
            # a reset the bus never noticed: the chip answers, asleep, with zeros
            chip._reset()
            before = len(samples)
            await until(lambda: len(samples) > before + 150, 10.0)
            zeros = [m for m in samples[before:] if m.gyro_radps[2] == 0.0]
            assert len(zeros) <= 110  # at most a second's worth at 100 Hz, then set up again
            assert samples[-1].gyro_radps[2] == pytest.approx(math.radians(45.0), abs=1e-3)
        finally:
            stop.set()
            await asyncio.to_thread(thread.join, 5.0)


@pytest.mark.parametrize(
    ("kind", "chip"),
    [
        ("mpu9250", FakeMpu(who=0x71, gyro_dps=(0.0, 0.0, 45.0))),
        ("qmc5883l", FakeQmc5883l(field_ut=(0.0, 30.0, -40.0))),
        ("hmc5883l", FakeHmc5883l(field_ut=(0.0, 30.0, -40.0))),
    ],
)
async def test_every_i2c_kind_reaches_navd_with_its_values(kind: str, chip: Any) -> None:
    async with running_daemon() as (daemon, port):
        samples, headings = record(daemon, Imu), record(daemon, CompassHeading)
        thread, stop = _program(kind, FakeBus(chip), port, "dev0")
        try:
            await until(lambda: len(samples) + len(headings) >= 5, 10.0)
        finally:
            stop.set()
            await asyncio.to_thread(thread.join, 5.0)
    if kind == "mpu9250":
        last = samples[-1]
        assert last.gyro_radps[2] == pytest.approx(math.radians(45.0), abs=1e-3)
        assert last.mag_ut is not None  # the AK8963's field came along
    else:  # the field along +y: facing east, bearing 90 degrees
        assert headings[-1].device_id == "dev0"
        assert headings[-1].bearing_deg == pytest.approx(90.0, abs=0.5)


async def test_a_bno055_is_an_imu_and_a_compass_to_navd() -> None:
    async with running_daemon() as (daemon, port):
        connected = record(daemon, DeviceConnected)
        samples, headings = record(daemon, Imu), record(daemon, CompassHeading)
        thread, stop = _program("bno055", FakeBus(FakeBno055(heading_deg=250.0)), port, "bno")
        try:
            await until(lambda: len(headings) >= 2 and len(samples) >= 10, 10.0)
            assert {c.device_id for c in connected} == {"bno", "bno-heading"}
            assert headings[-1].device_id == "bno-heading"
            # the chip's +y axis heads 250 deg: its +x axis, the one navd's mount turns, 340
            assert headings[-1].bearing_deg == pytest.approx(340.0, abs=0.07)
        finally:
            stop.set()
            await asyncio.to_thread(thread.join, 5.0)


def test_calibrate_compass_records_a_turn_and_writes_the_config(tmp_path: Path) -> None:
    chip = FakeQmc5883l()
    clock = [0.0]

    def tick(seconds: float) -> None:  # the robot turns a little with every sample
        clock[0] += seconds
        turn = 2.0 * math.pi * clock[0] / 20.0
        chip.field_ut = (
            15.0 + 30.0 * math.cos(turn) * 1.2,
            -4.0 + 30.0 * math.sin(turn) * 0.9,
            -40.0,
        )

    tick(0.0)
    fit, count = record_turn(
        "qmc5883l",
        "/dev/i2c-1",
        I2cOptions(rate_hz=20.0),
        25.0,
        open_bus=lambda path: FakeBus(chip),
        clock=lambda: clock[0],
        sleep=tick,
    )
    assert count >= 400
    assert fit.hard_iron_ut == pytest.approx((15.0, -4.0), abs=0.3)
    config = tmp_path / "navd.toml"
    config.write_text("# my robot\n[robot]\nname = 'rover'  # the yard one\n")
    table = "mounts.compasses.qmc5883l-i2c-1"
    values = {"hard_iron_ut": list(fit.hard_iron_ut), "soft_iron": [list(r) for r in fit.soft_iron]}
    set_table_keys(config, table, values)
    text = config.read_text()
    assert text.startswith("# my robot\n") and "# the yard one" in text  # the person's words stay
    mount = load_config(config).mounts.compasses["qmc5883l-i2c-1"]
    assert mount.hard_iron_ut == pytest.approx(fit.hard_iron_ut)
    np.testing.assert_allclose(mount.soft_iron, fit.soft_iron)
    # calibrating again replaces the keys in place; the table keeps its other keys
    set_table_keys(config, table, {"yaw_rad": 0.1})
    set_table_keys(config, table, values)
    text = config.read_text()
    assert text.count("hard_iron_ut") == 1 and "yaw_rad = 0.1" in text
    # a change that would make the file invalid leaves it as it was
    with pytest.raises(ConfigError, match="soft_iron"):
        set_table_keys(config, table, {"soft_iron": [[1.0, 1.0], [1.0, 1.0]]})
    assert config.read_text() == text
    assert list(tmp_path.iterdir()) == [config]  # no temporary file left behind
