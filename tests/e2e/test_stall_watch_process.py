"""The wheels stop when the daemon cannot stop them: the real daemon, driven by hand on a
chassis pseudo-terminal, is frozen (SIGSTOP: its loop writes nothing, as in a stall that
holds the GIL) and then killed (SIGKILL); each time the stall watch writes "0 0"."""

from __future__ import annotations

import contextlib
import signal
import threading
import time
from pathlib import Path
from typing import Any

from navd.sim import free_port
from navd.sim.devices import SerialLine
from navd.wire import Client, TeleopFrame
from tests.conftest import room_scan
from tests.e2e.conftest import READY_S

REACTION_S = 0.5  # safety.reaction_timeout_s, the default
# [s] the watch looks every period (50 ms); beyond that, a busy machine's scheduling
ALLOWANCE_S = 0.35


class Wheels(threading.Thread):
    """The chassis's end of the line: each wheel line with when it came."""

    def __init__(self, line: SerialLine) -> None:
        super().__init__(daemon=True)
        self.line = line
        self.lines: list[tuple[float, str]] = []
        self.halt = threading.Event()

    def run(self) -> None:
        pending = b""
        while not self.halt.wait(0.002):
            pending += self.line.read_available()
            *done, pending = pending.split(b"\n")
            now = time.monotonic()
            self.lines += [(now, x.decode().strip()) for x in done]

    def since(self, t: float) -> list[tuple[float, str]]:
        return [(at, text) for at, text in list(self.lines) if at > t]

    def wait_for(self, wanted: Any, after: float, timeout_s: float) -> float:
        """When the first line after ``after`` that ``wanted`` accepts came."""
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            hit = next((at for at, text in self.since(after) if wanted(text)), None)
            if hit is not None:
                return hit
            time.sleep(0.01)
        raise AssertionError(f"no such wheel line within {timeout_s} s: {self.since(after)[-5:]}")


def moving(text: str) -> bool:
    return text not in ("0 0", "")


def test_a_frozen_or_killed_daemon_has_its_wheels_stopped_by_the_watch(
    spawn_daemon: Any, tmp_path: Path
) -> None:
    line = SerialLine(tmp_path / "chassis-tty")
    wheels = Wheels(line)
    wheels.start()
    port = free_port()
    config = tmp_path / "navd.toml"
    config.write_text(
        f'[chassis]\nenabled = true\nport = "{tmp_path / "chassis-tty"}"\n[tcp]\nport = {port}\n'
        f'[viz]\nenabled = false\n[slam]\nmap_dir = "{tmp_path / "maps"}"\n'
    )
    daemon = spawn_daemon("run", "--config", str(config))
    daemon.wait_for("ready", timeout_s=READY_S)
    halt = threading.Event()

    def lidar() -> None:  # the room at 10 Hz, until the daemon is gone
        with (
            contextlib.suppress(OSError),
            Client("127.0.0.1", port, role="lidar", device_id="lidar0") as client,
        ):
            while not halt.wait(0.1):
                client.send(room_scan(time.monotonic()))

    def teleop() -> None:  # driven by hand at 0.2 m/s
        with contextlib.suppress(OSError), Client("127.0.0.1", port, device_id="driver") as driver:
            while not halt.wait(0.1):
                driver.send(TeleopFrame(linear_x=0.2, angular_z=0.0))

    for feed in (lidar, teleop):
        threading.Thread(target=feed, daemon=True).start()
    try:
        wheels.wait_for(moving, 0.0, 30.0)
        # frozen: the daemon writes nothing more; its last line was a moving one
        daemon.proc.send_signal(signal.SIGSTOP)
        frozen = time.monotonic()
        last = max(at for at, text in wheels.since(frozen - 1.0))
        stopped = wheels.wait_for(lambda t: t == "0 0", frozen, 5.0)
        assert stopped - last <= REACTION_S + ALLOWANCE_S
        time.sleep(0.5)  # it stays stopped while the daemon stays frozen, said every period
        assert all(text == "0 0" for _, text in wheels.since(stopped))
        assert len(wheels.since(stopped)) >= 3
        daemon.proc.send_signal(signal.SIGCONT)
        said = daemon.wait_for("chassis_stall_stopped", timeout_s=10.0)
        assert said["stop_lines"] >= 4
        wheels.wait_for(moving, time.monotonic(), 10.0)  # driven again once it runs
        # killed while driving: the watch sees its daemon go and stops the wheels at once
        daemon.proc.send_signal(signal.SIGKILL)
        killed = time.monotonic()
        stopped = wheels.wait_for(lambda t: t == "0 0", killed, 5.0)
        assert stopped - killed <= ALLOWANCE_S
        time.sleep(0.3)
        assert [text for _, text in wheels.since(stopped)] == []  # the watch is gone too
    finally:
        halt.set()
        if daemon.proc.poll() is None:
            daemon.proc.send_signal(signal.SIGCONT)
        wheels.halt.set()
        wheels.join(1.0)
        line.close()
