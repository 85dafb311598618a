"""The real daemon driven by hand on a chassis pseudo-terminal: a lidar streaming the room,
teleop at 0.2 m/s, and the wheel lines as the chassis reads them, each with when it came."""

from __future__ import annotations

import contextlib
import itertools
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from navd.sim import free_port
from navd.sim.devices import SerialLine
from navd.wire import Client, TeleopFrame
from tests.conftest import room_scan
from tests.e2e.conftest import READY_S, DaemonProcess

QUIET_GAP_S = 0.075  # [s] the largest gap between wheel lines (20 Hz) on a quiet machine


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

    def gap_limit_s(self, bar_s: float, before: float, window_s: float = 2.0) -> float:
        """[s] ``bar_s`` as this machine can keep it now: scaled by the largest gap between
        wheel lines over the ``window_s`` before ``before`` against a quiet machine's
        (QUIET_GAP_S), never below the bar. On a quiet machine it is the bar; beside CPU-bound
        processes every process waits its turn longer, navd's loop as well."""
        usual = self.largest_gap_s(before - window_s, before)
        return bar_s * max(1.0, usual / QUIET_GAP_S)

    def largest_gap_s(self, begin: float, end: float) -> float:
        """[s] the longest time without a wheel line between ``begin`` and ``end``."""
        times = [begin, *(at for at, _ in self.lines if begin < at < end), end]
        return max(b - a for a, b in itertools.pairwise(times))


def moving(text: str) -> bool:
    return text not in ("0 0", "")


@contextlib.contextmanager
def driven_daemon(
    spawn_daemon: Any, folder: Path, extra_toml: str = "", slam: str = ""
) -> Iterator[tuple[DaemonProcess, int, Wheels]]:
    """The real daemon, its chassis on a pseudo-terminal, driving at 0.2 m/s by hand with a
    lidar streaming the room; yields it, its TCP port and the wheels once they move.
    ``extra_toml``: more sections; ``slam``: more lines of the slam section."""
    line = SerialLine(folder / "chassis-tty")
    wheels = Wheels(line)
    wheels.start()
    port = free_port()
    config = folder / "navd.toml"
    config.write_text(
        f'[chassis]\nenabled = true\nport = "{folder / "chassis-tty"}"\n[tcp]\nport = {port}\n'
        f'[slam]\nmap_dir = "{folder / "maps"}"\n{slam}\n{extra_toml}'
    )
    daemon: DaemonProcess = spawn_daemon("run", "--config", str(config))
    halt = threading.Event()

    def lidar() -> None:  # the room at 10 Hz, until the daemon is gone
        sensor = Client("127.0.0.1", port, role="lidar", device_id="lidar0")
        with contextlib.suppress(OSError), sensor as client:
            while not halt.wait(0.1):
                client.send(room_scan(time.monotonic()))

    def teleop() -> None:  # driven by hand at 0.2 m/s
        with contextlib.suppress(OSError), Client("127.0.0.1", port, device_id="driver") as driver:
            while not halt.wait(0.1):
                driver.send(TeleopFrame(linear_x=0.2, angular_z=0.0))

    try:
        daemon.wait_for("ready", timeout_s=READY_S)
        for feed in (lidar, teleop):
            threading.Thread(target=feed, daemon=True).start()
        wheels.wait_for(moving, 0.0, 30.0)
        yield daemon, port, wheels
    finally:
        halt.set()
        wheels.halt.set()
        wheels.join(1.0)
        line.close()
