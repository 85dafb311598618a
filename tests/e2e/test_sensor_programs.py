"""Sensor programs on the real daemon: ``navd sensor KIND`` reads a device on a real
pseudo-terminal and streams to navd; a port that vanishes is logged and waited for, and the
program goes on."""

from __future__ import annotations

import math
import os
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from navd.lifecycle.messages import CompassHeading, GpsFix, LaserScan
from navd.sim.devices import GnssState, Ld06Device, NmeaDevice, SerialLine
from navd.viz import read_recording, recording_files
from navd.wire import Client, StatusFrame, SubscribeFrame
from tests.e2e.ptys import linked_pty
from tests.sensors.test_nmea import GGA

pytestmark = pytest.mark.e2e


def _nmea_fixes(master: int, stop: threading.Event) -> None:
    """A receiver sending one GGA a tenth of a second."""
    while not stop.wait(0.1):
        try:
            os.write(master, (GGA + "\r\n").encode())
        except OSError:
            return  # the port was pulled


def _devices(port: int) -> dict[str, Any]:
    with Client("127.0.0.1", port, device_id="watcher", timeout_s=5.0) as ui:
        ui.request(SubscribeFrame(rate_hz=20))
        status = ui.receive_type(StatusFrame)
    return {d.device_id: d for d in status.devices}


def _received(folder: Path) -> list[Any]:
    """The sensor messages the daemon recorded."""
    (file,) = recording_files(folder)
    return [m for _, m in read_recording(file).messages() if isinstance(m, LaserScan | GpsFix)]


def _check_values(kind: str, messages: list[Any]) -> None:
    assert len(messages) >= 3
    for message in messages[1:]:  # (a program's first turn begins where it began reading)
        assert message.device_id == f"{kind}0"
        # stamped by the program at the device's bytes, mapped onto navd's clock: never
        # after their arrival, and not long before it
        assert 0.0 <= message.received - message.stamp < 0.5
        if kind == "ld06":  # a turn from the lidar's front, clockwise, in the order measured
            assert message.angle_min == pytest.approx(0.0, abs=0.01)
            assert message.angle_increment == pytest.approx(-math.pi / 360)
            assert message.time_increment == pytest.approx(0.1 / 720, rel=0.05)
            seen = message.ranges[np.isfinite(message.ranges)]
            assert seen.size > 300 and np.allclose(seen, 3.0, atol=0.001)  # the 3 m room
            assert message.intensities is not None
        else:
            assert message.latitude_deg == pytest.approx(48.1173, abs=1e-6)
            assert message.longitude_deg == pytest.approx(11.516667, abs=1e-6)
            assert message.horizontal_accuracy_m == pytest.approx(0.9 * 4.0)  # HDOP x 4 m


@pytest.mark.parametrize(("kind", "role"), [("ld06", "lidar"), ("nmea", "gps")])
def test_a_sensor_program_streams_a_serial_device_and_outlives_its_port(
    daemon_on_port: Any, tmp_path: Path, kind: str, role: str
) -> None:
    folder = tmp_path / "recorded"
    daemon, port = daemon_on_port(f'[record]\nenabled = true\ndir = "{folder}"\n')
    stop = threading.Event()
    if kind == "ld06":  # an LD06 in a round room 3 m across, at its own rate and rhythm
        line = SerialLine(tmp_path / "ttyUSB0")
        lidar = Ld06Device(lambda angle_deg: (3.0, 120))
        device_thread = threading.Thread(target=lidar.stream, args=(line, stop), daemon=True)
        link, unplug = tmp_path / "ttyUSB0", line.close
    else:
        master, slave, link = linked_pty(tmp_path)
        device_thread = threading.Thread(target=_nmea_fixes, args=(master, stop), daemon=True)

        def unplug() -> None:
            link.unlink()
            os.close(master)
            os.close(slave)

    device_thread.start()
    log = (tmp_path / "sensor.log").open("w")
    program = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "navd",
            "sensor",
            kind,
            "--port",
            str(link),
            "--navd",
            f"127.0.0.1:{port}",
            "--device-id",
            f"{kind}0",
        ],
        stdout=log,
        stderr=subprocess.STDOUT,
    )
    try:
        deadline = time.monotonic() + 20.0
        seen = None
        while time.monotonic() < deadline:
            time.sleep(1.0)
            seen = _devices(port).get(f"{kind}0")
            if seen is not None and seen.accepted > 2:
                break
        assert seen is not None and seen.kind == role and seen.accepted > 2
        assert seen.rejected == 0
        # The port vanishes (a USB adapter pulled out): the program says so and waits.
        stop.set()
        device_thread.join(2.0)
        unplug()
        time.sleep(2.0)
        assert program.poll() is None, "the sensor program died with its port"
    finally:
        program.terminate()
        program.wait(10)
        log.close()
    daemon.proc.terminate()  # the recording is closed: what navd received, value by value
    daemon.proc.wait(10)
    _check_values(kind, _received(folder))
    said = (tmp_path / "sensor.log").read_text()
    assert "device_lost" in said or "device_unavailable" in said
    assert said.count("device_unavailable") <= 1  # said once, not once per retry


def test_an_rtk_receiver_with_two_antennas_places_and_heads_the_robot(
    daemon_on_port: Any, tmp_path: Path
) -> None:
    """RTK fixed without GST arrives good to centimetres, and its HDT heading, sent on the
    same connection, turns the robot: true north is the map's +y (less the grid's
    convergence, under 2 deg here)."""
    folder = tmp_path / "recorded"
    daemon, port = daemon_on_port(
        f'[record]\nenabled = true\ndir = "{folder}"\n'
        "[world]\ndatum_latitude_deg = 48.1173\ndatum_longitude_deg = 11.516667\n"
    )
    line = SerialLine(tmp_path / "ttyACM0")
    receiver = NmeaDevice(GnssState(quality=4, heading_deg=0.0), rate_hz=5.0, baud=38400)
    stop = threading.Event()
    streaming = threading.Thread(target=receiver.stream, args=(line, stop), daemon=True)
    streaming.start()
    program = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "navd",
            "sensor",
            "nmea",
            "--port",
            str(tmp_path / "ttyACM0"),
            "--baud",
            "38400",
            "--navd",
            f"127.0.0.1:{port}",
            "--device-id",
            "gnss0",
        ],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.STDOUT,
    )
    try:
        pose = None
        deadline = time.monotonic() + 20.0
        while time.monotonic() < deadline and pose is None:
            time.sleep(0.5)
            with Client("127.0.0.1", port, device_id="watcher", timeout_s=5.0) as ui:
                ui.request(SubscribeFrame(rate_hz=20))
                pose = ui.receive_type(StatusFrame).pose
        assert pose is not None, "the fixes and heading did not place the robot"
        assert math.hypot(pose.x, pose.y) < 0.1
        assert abs(math.remainder(pose.yaw - math.pi / 2, 2 * math.pi)) < math.radians(3)
    finally:
        program.terminate()
        program.wait(10)
        stop.set()
        streaming.join(2.0)
        line.close()
    daemon.proc.terminate()
    daemon.proc.wait(10)
    (file,) = recording_files(folder)
    fixes = [m for _, m in read_recording(file).messages() if isinstance(m, GpsFix)]
    headings = [m for _, m in read_recording(file).messages() if isinstance(m, CompassHeading)]
    assert fixes and all(f.horizontal_accuracy_m <= 0.05 for f in fixes)
    assert headings and all(h.device_id == "gnss0" and h.true_north for h in headings)
