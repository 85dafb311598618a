"""``navd sensor rplidar`` against an emulated RPLIDAR on a real pseudo-terminal and the real
daemon: the program asks the lidar to scan, its turns reach the daemon with the right ranges
at the right angles, a lidar that stops mid-scan is asked again, and a vanished port is
waited for."""

from __future__ import annotations

import math
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from navd.sim.devices import RplidarDevice, SerialLine
from tests.e2e.test_viz_process import logged
from tests.sensors.test_rplidar import room
from tests.viz.foxglove_client import FoxgloveClient

pytestmark = pytest.mark.e2e


SENSOR = [sys.executable, "-m", "navd", "sensor", "rplidar"]


def _wait(predicate: Any, timeout_s: float = 10.0) -> bool:
    deadline = time.monotonic() + timeout_s
    while not predicate() and time.monotonic() < deadline:
        time.sleep(0.1)
    return bool(predicate())


def _asked_again(requests: list[int]) -> bool:
    """A STOP followed by a GET_HEALTH among ``requests``."""
    return any(requests[i : i + 2] == [0x25, 0x52] for i in range(len(requests) - 1))


def _a1_on(
    link: Path,
) -> tuple[RplidarDevice, SerialLine, threading.Event, threading.Thread]:
    """An A1 on a serial line at ``link``, at its own rate and rhythm, serving until told."""
    line = SerialLine(link)
    device = RplidarDevice(room, model="A1")
    stop = threading.Event()
    serving = threading.Thread(target=device.serve, args=(line, stop), daemon=True)
    serving.start()
    return device, line, stop, serving


async def test_an_rplidar_streams_turns_to_navd_and_outlives_a_hang_and_its_port(
    spawn_daemon: Any, tmp_path: Path
) -> None:
    config = tmp_path / "navd.toml"
    config.write_text("[tcp]\nport = 0\n[viz]\nport = 0\npage_port = 0\n")
    daemon = spawn_daemon("run", "--config", str(config))
    logged(daemon, "ready")
    tcp_port = logged(daemon, "listening")["port"]
    viewer = await FoxgloveClient.open(logged(daemon, "viz_listening")["port"])
    link = tmp_path / "ttyUSB0"
    device, line, stop, serving = _a1_on(link)
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
        for _ in range(2):  # the first turn may be partial: the second is whole
            _, shown = await viewer.receive("/scan", timeout_s=30.0)
        ranges = np.array(shown.ranges, dtype=float)
        angles = np.linspace(shown.start_angle, shown.end_angle, ranges.size)
        angles = np.remainder(angles + math.pi, 2 * math.pi) - math.pi  # (clockwise order)
        right = np.abs(angles + math.pi / 2) < math.radians(5)  # the wall on its right
        left = np.abs(angles - math.pi / 2) < math.radians(5)
        assert np.nanmax(np.abs(ranges[right] - 1.0)) < 0.005
        assert np.nanmax(np.abs(ranges[left] - 3.0)) < 0.005
        _check_conversation(device.requests, device.deaf_requests)
        # The lidar stops mid-scan (its firmware hung): the program asks it again.
        device.frozen.set()
        asked = len(device.requests)
        silent = _wait(lambda: "device_silent" in log_path.read_text(), timeout_s=30.0)
        assert silent, "the program did not notice the silence"  # (2 s, on an idle machine)
        device.frozen.clear()
        # a STOP then a GET_HEALTH heard (a pair may be cut by the thaw: a later one counts)
        assert _wait(lambda: _asked_again(device.requests[asked:]), timeout_s=30.0), (
            "not asked again"
        )
        assert _wait(lambda: device.streaming is not None), "the scan was not started again"
        # The port vanishes (the USB adapter pulled out): said once, waited for.
        stop.set()
        serving.join(2.0)
        line.close()
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


def _check_conversation(requests: list[int], deaf: list[int]) -> None:
    """STOP, GET_HEALTH, GET_INFO, then the A1's typical mode. On a busy machine the
    emulator may read a STOP and the GET_HEALTH sent 2 ms after it in one go, take it as
    within Slamtec's 1 ms, and not hear it; the program then asks again. (The 1 ms itself is
    checked on a virtual clock: tests/sensors/test_rplidar.py.)"""
    first_info = requests.index(0x50)
    assert requests[0] == 0x25
    assert requests[first_info - 2 : first_info + 1] == [0x25, 0x52, 0x50]
    assert all(r in requests for r in deaf)  # each asked again
    assert 0x82 in requests
