"""``navd sensor rplidar`` against an emulated RPLIDAR on a real pseudo-terminal and the real
daemon: the program asks the lidar to scan, its turns reach the daemon with the right ranges
at the right angles, a lidar that stops mid-scan is asked again, and a vanished port is
waited for."""

from __future__ import annotations

import math
import os
import select
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from tests.e2e.ptys import linked_pty
from tests.e2e.test_viz_process import logged
from tests.sensors.rplidar_emulator import RplidarEmulator
from tests.sensors.test_rplidar import room
from tests.viz.foxglove_client import FoxgloveClient

pytestmark = pytest.mark.e2e


SENSOR = [sys.executable, "-m", "navd", "sensor", "rplidar"]


def _wait(predicate: Any, timeout_s: float = 10.0) -> bool:
    deadline = time.monotonic() + timeout_s
    while not predicate() and time.monotonic() < deadline:
        time.sleep(0.1)
    return bool(predicate())


class _SerialDevice(threading.Thread):
    """The emulated lidar on the pseudo-terminal's device end: answers what it hears and
    streams ten turns a second while asked to scan, unless told to hang."""

    def __init__(self, master: int, emulator: RplidarEmulator) -> None:
        super().__init__(daemon=True)
        self.master, self.emulator = master, emulator
        self.hung = threading.Event()
        self.stop = threading.Event()

    def run(self) -> None:
        next_turn = time.monotonic()
        while not self.stop.is_set():
            try:
                ready = select.select([self.master], [], [], 0.02)[0]
                if ready:
                    answer = self.emulator.hear(os.read(self.master, 4096))
                    if answer and not self.hung.is_set():
                        os.write(self.master, answer)
                if time.monotonic() >= next_turn:
                    next_turn += 0.1
                    if not self.hung.is_set():
                        os.write(self.master, self.emulator.turn())
            except OSError:
                return  # the port was pulled


async def test_an_rplidar_streams_turns_to_navd_and_outlives_a_hang_and_its_port(
    spawn_daemon: Any, tmp_path: Path
) -> None:
    config = tmp_path / "navd.toml"
    config.write_text("[tcp]\nport = 0\n[viz]\nport = 0\npage_port = 0\n")
    daemon = spawn_daemon("run", "--config", str(config))
    logged(daemon, "ready")
    tcp_port = logged(daemon, "listening")["port"]
    viewer = await FoxgloveClient.open(logged(daemon, "viz_listening")["port"])
    master, slave, link = linked_pty(tmp_path)
    emulator = RplidarEmulator(room, model=0x18)  # an A1
    device = _SerialDevice(master, emulator)
    device.start()
    log_path = tmp_path / "sensor.log"
    log = log_path.open("w")
    navd = f"127.0.0.1:{tcp_port}"
    program = subprocess.Popen(
        [*SENSOR, "--port", str(link), "--navd", navd, "--device-id", "lidar0"],
        stdout=log,
        stderr=subprocess.STDOUT,
    )
    try:
        await viewer.wait_for_topics({"/scan"})
        await viewer.subscribe("/scan")
        _, shown = await viewer.receive("/scan", timeout_s=30.0)
        ranges = np.array(shown.ranges, dtype=float)
        angles = np.linspace(shown.start_angle, shown.end_angle, ranges.size)
        right = np.abs(angles + math.pi / 2) < math.radians(5)  # the wall on its right
        left = np.abs(angles - math.pi / 2) < math.radians(5)
        assert np.nanmax(np.abs(ranges[right] - 1.0)) < 0.005
        assert np.nanmax(np.abs(ranges[left] - 3.0)) < 0.005
        assert emulator.requests[:4] == [0x25, 0x52, 0x50, 0x20]  # stop, health, info, scan
        # The lidar stops mid-scan (its firmware hung): the program asks it again.
        asked = len(emulator.requests)
        device.hung.set()
        _wait(lambda: len(emulator.requests) > asked)
        assert emulator.requests[asked:][:2] == [0x25, 0x52], "not asked again when silent"
        device.hung.clear()
        emulator.requests.clear()
        assert _wait(lambda: 0x20 in emulator.requests), "the scan was not started again"
        # The port vanishes (the USB adapter pulled out): said once, waited for.
        device.stop.set()
        device.join(2.0)
        link.unlink()
        os.close(master)
        os.close(slave)
        time.sleep(2.0)
        assert program.poll() is None, "the sensor program died with its port"
    finally:
        program.terminate()
        program.wait(10)
        log.close()
        await viewer.close()
    said = log_path.read_text()
    assert "lidar_info" in said and "A1" in said
    assert "device_silent" in said
    assert "device_lost" in said or "device_unavailable" in said
    assert said.count("device_unavailable") <= 1
