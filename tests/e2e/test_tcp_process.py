"""Sensors and control clients against the real daemon process, on real sockets."""

from __future__ import annotations

import json
import threading
import time
from typing import Any

import pytest

from navd.wire import (
    Client,
    DeviceInfo,
    HeadingFrame,
    ImuFrame,
    PingFrame,
    Pong,
    Reply,
    ScanFrame,
    SensorFrame,
    StatusFrame,
    SubscribeFrame,
)
from tests.e2e.conftest import run_navd

pytestmark = pytest.mark.e2e

IMU = ImuFrame(stamp=None, angular_velocity=(0.0, 0.0, 0.1), linear_acceleration=(0, 0, 9.81))
SCAN = ScanFrame(
    stamp=None,
    angle_min=-1.57,
    angle_increment=0.01,
    range_min=0.1,
    range_max=10.0,
    ranges=[2.0] * 315,
)
DONE = Pong(id="done")


class Streamer(threading.Thread):
    """A sensor client streaming one frame kind at a rate until stopped; counts replies."""

    def __init__(
        self, port: int, role: str, device_id: str, frame: SensorFrame, rate_hz: float
    ) -> None:
        super().__init__(daemon=True)
        # a good client may hear nothing for a long time: no read timeout
        self.client = Client("127.0.0.1", port, role=role, device_id=device_id, timeout_s=None)
        self.frame = frame
        self.period_s = 1.0 / rate_hz
        self.sent = 0
        self.replies: list[Reply] = []
        self._stop_event = threading.Event()
        self._reader = threading.Thread(target=self._read, daemon=True)

    def run(self) -> None:
        self._reader.start()
        start = time.monotonic()
        while not self._stop_event.is_set():
            self.client.send(self.frame.model_copy(update={"stamp": time.monotonic()}))
            self.sent += 1
            time.sleep(max(0.0, start + self.sent * self.period_s - time.monotonic()))

    def _read(self) -> None:
        while True:
            try:
                frame = self.client.receive()
            except Exception:
                return
            self.replies.append(frame)

    def finish(self) -> None:
        """Stop streaming and wait until the daemon has answered everything sent."""
        self._stop_event.set()
        self.join()
        self.client.send(PingFrame(id="done"))
        deadline = time.monotonic() + 5.0
        while DONE not in self.replies:
            assert time.monotonic() < deadline, "no pong"
            time.sleep(0.01)
        self.replies.remove(DONE)


def devices(port: int) -> dict[str, DeviceInfo]:
    with Client("127.0.0.1", port, device_id="probe") as control:
        control.request(SubscribeFrame(rate_hz=10))
        frame = control.receive_type(StatusFrame)
        return {d.device_id: d for d in frame.devices if d.device_id != "probe"}


def test_reconnecting_sensor_while_another_streams(daemon_on_port: Any) -> None:
    daemon, port = daemon_on_port()
    imu = Streamer(port, "imu", "imu0", IMU, rate_hz=200)
    imu.start()
    lidar = Client("127.0.0.1", port, role="lidar", device_id="lidar0")
    for _ in range(5):
        lidar.send(SCAN)
    time.sleep(0.2)
    assert set(devices(port)) == {"imu0", "lidar0"}
    lidar.close()
    time.sleep(0.2)
    assert set(devices(port)) == {"imu0"}
    lidar = Client("127.0.0.1", port, role="lidar", device_id="lidar0")
    lidar.send(SCAN)
    time.sleep(0.2)
    listed = devices(port)
    assert set(listed) == {"imu0", "lidar0"}
    assert listed["lidar0"].accepted == 1  # a new session
    imu.finish()
    assert imu.replies == []
    assert devices(port)["imu0"].accepted == imu.sent
    lidar.close()
    daemon.wait_for("device_lost", timeout_s=2.0)
    assert daemon.proc.poll() is None


def test_status_command_shows_devices(daemon_on_port: Any) -> None:
    _, port = daemon_on_port()
    with Client("127.0.0.1", port, role="compass", device_id="compass0") as compass:
        # A compass streams (10 Hz); one heading alone would go stale before a slow CLI
        # start-up has fetched the status.
        done = threading.Event()

        def stream() -> None:
            while not done.is_set():
                compass.send(HeadingFrame(stamp=None, bearing_deg=90.0, accuracy_deg=2.0))
                done.wait(0.1)

        streamer = threading.Thread(target=stream)
        streamer.start()
        try:
            result = run_navd("status", "--once", "--port", str(port))
        finally:
            done.set()
            streamer.join()
    assert result.returncode == 0, result.stderr
    assert "compass0(compass)" in result.stdout and "[idle]" in result.stdout
    goal = run_navd("goal", "1.5", "2", "--yaw", "0.3", "--id", "g7", "--port", str(port))
    assert goal.returncode == 0, goal.stderr
    assert goal.stdout.splitlines()[0] == "goal g7 sent: (1.50, 2.00) m, heading 0.30 rad"
    raw = run_navd("goal", "1", "2", "--id", "g8", "--json", "--port", str(port))
    assert json.loads(raw.stdout.splitlines()[0]) == {
        "type": "ack",
        "request": "goal",
        "goal_id": "g8",
    }
    canceled = run_navd("cancel", "--id", "g8", "--port", str(port))
    assert canceled.returncode == 0 and canceled.stdout.strip() == "cancel of g8 accepted"


def test_busy_port_is_a_clear_error_and_exit_1(daemon_on_port: Any, tmp_path: Any) -> None:
    first, port = daemon_on_port()
    config = tmp_path / "second.toml"
    config.write_text(f"[tcp]\nport = {port}\n")
    second = run_navd("run", "--config", str(config))
    assert second.returncode == 1
    failure = [json.loads(line) for line in second.stderr.splitlines() if '"daemon_failed"' in line]
    assert failure and f"cannot listen on 127.0.0.1:{port}" in failure[0]["error"]
    assert "Traceback" not in second.stderr
    assert first.proc.poll() is None  # the first daemon is unaffected
