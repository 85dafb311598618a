"""The programs for a robot's other sensors: an MCU's lines (bumpers, cliff sensors, range
sensors, the battery), a Benewake TFmini, a TI INA219; and an MCU's lines reaching the real
daemon, each kind on its own connection."""

from __future__ import annotations

import math
import os
import threading
from pathlib import Path

import pytest

from navd.lifecycle.messages import BatteryState, Contact, RangeReading
from navd.sensors.i2c_runner import I2cOptions, make_chip
from navd.sensors.ina219 import charge_of
from navd.sensors.link import Link
from navd.sensors.mcu_lines import McuLines
from navd.sensors.runner import run_sensor
from navd.sensors.tfmini import MIN_STRENGTH, Tfmini, tfmini_frame
from navd.sim.devices import SerialLine
from navd.wire import BatteryFrame, ContactFrame, RangeFrame
from tests.drivers.conftest import record, running_daemon, until
from tests.sensors.chip_fakes import FakeBus, FakeIna219


def test_mcu_lines_become_contact_range_and_battery_frames() -> None:
    mcu = McuLines()
    frames = mcu.feed(
        b"# an MCU's greeting\r\nbumper left 1\ncliff front 0\nrange sonar 0.42 20 3.5\n"
        b"range sonar inf\nbattery 12.4 -1.2 81 discharging\n",
        5.0,
    )
    bump, cliff, near, clear, battery = frames
    assert isinstance(bump, ContactFrame) and bump.kind == "bumper" and bump.triggered
    assert isinstance(cliff, ContactFrame) and cliff.kind == "cliff" and not cliff.triggered
    assert isinstance(near, RangeFrame) and near.range == 0.42 and near.max_range == 3.5
    assert near.field_of_view == pytest.approx(math.radians(20))
    assert isinstance(clear, RangeFrame) and clear.range is None
    assert isinstance(battery, BatteryFrame)
    assert (battery.voltage, battery.current, battery.percentage) == (12.4, -1.2, 0.81)
    assert battery.charging is False


def test_a_line_that_is_no_reading_or_impossible_is_counted() -> None:
    mcu = McuLines()
    assert mcu.feed(b"hello world\nbumper left 2\nbattery -3\nrange s far\n", 1.0) == []
    assert mcu.counts() == {"unparsed": 2, "out_of_range": 2}


def test_a_tfmini_sends_its_nearest_good_reading_a_period() -> None:
    tfmini = Tfmini()
    data = tfmini_frame(250, 800) + tfmini_frame(180, 900) + tfmini_frame(30, MIN_STRENGTH - 1)
    assert tfmini.feed(data, 0.0) == []  # the period is not over
    (frame,) = tfmini.feed(b"\x00garbage" + tfmini_frame(400, 65535), 0.06)
    assert isinstance(frame, RangeFrame) and frame.range == 1.8  # weak and overexposed left out
    broken = bytearray(tfmini_frame(100, 500))
    broken[8] ^= 0xFF
    tfmini.feed(bytes(broken), 0.07)
    assert tfmini.counts()["bad_checksums"] == 1 and tfmini.counts()["skipped_bytes"] >= 8
    (clear,) = tfmini.feed(tfmini_frame(0, 0), 0.2)
    assert isinstance(clear, RangeFrame) and clear.range is None


def test_an_ina219_gives_the_batterys_voltage_current_and_charge() -> None:
    chip = FakeIna219(battery_v=11.4, current_a=2.0)
    ina = make_chip("ina219", FakeBus(chip), I2cOptions(battery=(0.1, 3, "li-ion", 1)))
    ina.setup()
    (frame,) = ina.poll(1.0)
    assert isinstance(frame, BatteryFrame)
    assert frame.voltage == pytest.approx(11.4, abs=0.005)
    assert frame.current == pytest.approx(-2.0, abs=0.001)  # discharging: negative
    assert frame.percentage == pytest.approx(charge_of(11.4, 3, "li-ion"), abs=0.01)
    assert 0.4 < frame.percentage < 0.6 and frame.charging is False  # 3.8 V a cell: about half
    chip.current_a = -1.0  # a charger pushes current back in
    (charging,) = ina.poll(2.0)
    assert isinstance(charging, BatteryFrame) and charging.charging is True


def test_charge_follows_each_chemistrys_table() -> None:
    assert charge_of(4.2 * 3, 3, "li-ion") == 1.0 and charge_of(3.0 * 3, 3, "li-ion") == 0.0
    assert charge_of(3.3 * 4, 4, "lifepo4") == pytest.approx(0.8)
    assert charge_of(12.7, 6, "lead-acid") > 0.9


def _mcu(line: SerialLine, stop: threading.Event) -> None:
    while not stop.wait(0.1):
        os.write(line.fd, b"bumper front 1\nrange sonar 0.8\nbattery 12.0 -0.5\n")


async def test_an_mcus_lines_reach_navd_each_kind_on_its_connection(tmp_path: Path) -> None:
    line = SerialLine(tmp_path / "ttyACM0")
    stop = threading.Event()
    mounts = {"ranges": {"sonar": {"x_m": 0.2}}}
    async with running_daemon(mounts=mounts) as (daemon, port):
        contacts, ranges = record(daemon, Contact), record(daemon, RangeReading)
        batteries = record(daemon, BatteryState)
        link = Link(
            port=str(tmp_path / "ttyACM0"),
            baud=115200,
            host="127.0.0.1",
            navd_port=port,
            device_id="mcu0",
        )
        program = threading.Thread(target=run_sensor, args=("mcu", link, stop), daemon=True)
        program.start()
        try:
            # the MCU says its state every 0.1 s (more than the 0.25 s it must)
            saying = threading.Thread(target=_mcu, args=(line, stop), daemon=True)
            saying.start()
            await until(lambda: bool(contacts and batteries and ranges), 15.0)
            assert contacts[-1].device_id == "mcu0" and contacts[-1].triggered
            assert contacts[-1].sensor == "front"
            assert batteries[-1].device_id == "mcu0-battery"
            assert batteries[-1].voltage_v == 12.0
            assert ranges[-1].device_id == "mcu0-range" and ranges[-1].range_m == 0.8
        finally:
            stop.set()
            program.join(5.0)
            line.close()
