"""``navd bench safety --lidar-program KIND``: a lidar program on an emulated lidar that
streams at the device's baud rate and rhythm, and what the robot makes of it.

The real daemon (``navd run``, its chassis on a pseudo-terminal) is driven by hand at 0.2 m/s
(teleop, ten commands a second) while ``navd sensor KIND`` reads the emulated device (an
LD06, or an RPLIDAR of a given model) on a pseudo-terminal of its own and streams to the
daemon through a relay that times each scan as it reaches navd. Optionally ``busy``
CPU-bound processes run beside it all. Figures over ``seconds``:

- ``stale_events`` and ``safety_holds``: the daemon's own ``device_stale`` and
  ``safety_hold`` log lines (a healthy lidar should cause none);
- ``delivery_ms``: from the end of a turn (the device's last sample of it) to its scan
  reaching navd's socket, p50/p90/max; ``stamp_error_ms``: the scan's stamp against the
  turn's true start;
- then the device is frozen (it hangs: no byte leaves it) ``freezes`` times, and
  ``freeze_to_stop_ms`` is the time from each freeze to the first "0 0" on the chassis
  line, which the daemon promises within 300 ms.
No peer stack runs here; the figures stand against the daemon's promise.
"""

from __future__ import annotations

import contextlib
import json
import os
import socket
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

from navd.sim import free_port
from navd.sim.devices import SerialLine
from navd.wire import Client, ScanFrame, TeleopFrame, decode_sensor

__all__ = ["run"]

TELEOP_HZ = 10.0
TELEOP_MPS = 0.2
PROMISE_MS = 300.0
SETTLE_S = 3.0  # [s] after the program connects, before measuring (its clock offset)
FREEZE_GAP_S = 3.0  # [s] between two freezes, after the lidar is back


def run(
    kind: str = "ld06",
    *,
    seconds: float = 60.0,
    busy: int = 0,
    model: str = "A1",
    freezes: int = 5,
) -> dict[str, Any]:
    """Run the benchmark; its figures (see the module docstring)."""
    hogs = [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(busy)]
    try:
        with tempfile.TemporaryDirectory(prefix="navd-bench-lidar-") as folder:
            return _Run(Path(folder), kind, model).measure(seconds, freezes) | {
                "lidar": kind if kind == "ld06" else f"rplidar {model}",
                "seconds": seconds,
                "busy_processes": busy,
                "promise_ms": PROMISE_MS,
            }
    finally:
        for hog in hogs:
            hog.kill()
            hog.wait()


class _Run:
    """The daemon, the chassis line, the device, the relay and the program of one run."""

    def __init__(self, folder: Path, kind: str, model: str) -> None:
        self.folder = folder
        self.chassis = SerialLine(folder / "chassis-tty")
        self.wheels: list[tuple[float, str]] = []  # (when, the line) as the chassis read it
        self.port = free_port()
        config = folder / "navd.toml"
        config.write_text(
            f'[chassis]\nenabled = true\nport = "{folder / "chassis-tty"}"\n'
            f"[tcp]\nport = {self.port}\n"
            '[viz]\nenabled = false\n[logging]\nformat = "json"\n'
            f'[slam]\nmap_dir = "{folder / "maps"}"\n',
            encoding="utf-8",
        )
        self.log_path = folder / "navd.log"
        with self.log_path.open("wb") as log:
            self.daemon = subprocess.Popen(
                [sys.executable, "-m", "navd", "run", "--config", str(config)],
                stdout=log,
                stderr=subprocess.STDOUT,
            )
        device = [sys.executable, "-m", "navd.sim.devices.process", kind, "--model", model]
        self.device = subprocess.Popen(
            device, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True
        )
        self.kind = "ld06" if kind == "ld06" else "rplidar"
        self.relay = _Relay(self.port)
        self.program: subprocess.Popen[bytes] | None = None
        self.stop = threading.Event()

    def measure(self, seconds: float, freezes: int) -> dict[str, Any]:
        try:
            return self._measure(seconds, freezes)
        finally:
            self.stop.set()
            for process in (self.program, self.daemon):
                if process is not None:
                    process.terminate()
                    with contextlib.suppress(subprocess.TimeoutExpired):
                        process.wait(10)
            if self.device.stdin is not None:
                with contextlib.suppress(OSError):
                    self.device.stdin.close()
            self.device.wait(10)
            self.relay.close()
            self.chassis.close()

    def _measure(self, seconds: float, freezes: int) -> dict[str, Any]:
        assert self.device.stdout is not None and self.device.stdin is not None
        tty = json.loads(self.device.stdout.readline())["tty"]
        _wait_for(lambda: _log_has(self.log_path, '"ready"'), 60.0, "navd did not start")
        threading.Thread(target=self._read_wheels, daemon=True).start()
        self._say("go")
        self.program = subprocess.Popen(
            [
                sys.executable,
                "-m",
                "navd",
                "sensor",
                self.kind,
                "--port",
                tty,
                "--navd",
                f"127.0.0.1:{self.relay.port}",
                "--device-id",
                "lidar0",
                "--log-level",
                "warning",
            ],
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
        _wait_for(lambda: len(self.relay.lines) >= 4, 30.0, "no scan reached navd")
        threading.Thread(target=self._teleop, daemon=True).start()
        time.sleep(SETTLE_S)
        log_start = self.log_path.stat().st_size
        begin = time.monotonic()
        first_line = len(self.relay.lines)
        time.sleep(seconds)
        scans = self.relay.scans(first_line)
        said = self.log_path.read_bytes()[log_start:].decode("utf-8", "replace")
        figures: dict[str, Any] = {
            "scans": len(scans),
            "stale_events": said.count('"device_stale"'),
            "safety_holds": said.count('"safety_hold"'),
            "zero_lines_while_driving": sum(
                1 for at, text in self.wheels if at >= begin + 0.5 and text == "0 0"
            ),
        }
        figures |= self._stop_times(freezes)
        self._say("stop")
        turns = json.loads(self.device.stdout.readline())["turns"]
        figures |= _delivery(scans, turns)
        return figures

    def _stop_times(self, freezes: int) -> dict[str, Any]:
        delays = []
        for _ in range(freezes):
            frozen_at = time.monotonic()
            self._say("freeze")
            zero = self._first_zero_after(frozen_at)
            delays.append((zero - frozen_at) * 1e3)
            self._say("thaw")
            time.sleep(FREEZE_GAP_S)
        if not delays:
            return {}
        return {
            "freeze_to_stop_ms": [round(d, 1) for d in delays],
            "freeze_to_stop_max_ms": round(max(delays), 1),
            "all_within_promise": max(delays) <= PROMISE_MS,
        }

    def _first_zero_after(self, since: float) -> float:
        """[s] the first "0 0" the chassis read after ``since`` (waited for)."""

        def zero() -> float | None:
            return next((at for at, text in self.wheels if at > since and text == "0 0"), None)

        _wait_for(lambda: zero() is not None, 10.0, "the wheels were not stopped")
        found = zero()
        assert found is not None
        return found

    def _say(self, word: str) -> None:
        assert self.device.stdin is not None
        self.device.stdin.write(word + "\n")
        self.device.stdin.flush()

    def _read_wheels(self) -> None:
        pending = b""
        while not self.stop.is_set():
            data = self.chassis.read_available()
            if not data:
                time.sleep(0.002)
                continue
            now = time.monotonic()
            pending += data
            *lines, pending = pending.split(b"\n")
            self.wheels.extend((now, line.decode(errors="replace").strip()) for line in lines)

    def _teleop(self) -> None:
        with Client("127.0.0.1", self.port, device_id="bench-driver") as driver:
            while not self.stop.wait(1.0 / TELEOP_HZ):
                driver.send(TeleopFrame(linear_x=TELEOP_MPS, angular_z=0.0))


class _Relay:
    """Passes one sensor program's connection to navd, timing each scan line as it goes."""

    def __init__(self, navd_port: int) -> None:
        self.navd_port = navd_port
        self.listener = socket.create_server(("127.0.0.1", 0))
        self.port = self.listener.getsockname()[1]
        self.lines: list[tuple[float, bytes]] = []  # (arrival [s], the line) after the hello
        self._sockets: list[socket.socket] = [self.listener]
        threading.Thread(target=self._accept, daemon=True).start()

    def _accept(self) -> None:
        with contextlib.suppress(OSError):
            while True:
                program, _ = self.listener.accept()
                navd = socket.create_connection(("127.0.0.1", self.navd_port))
                self._sockets += [program, navd]
                threading.Thread(target=self._pass, args=(navd, program), daemon=True).start()
                threading.Thread(target=self._up, args=(program, navd), daemon=True).start()

    def _pass(self, source: socket.socket, sink: socket.socket) -> None:
        with contextlib.suppress(OSError):
            while data := source.recv(65536):
                sink.sendall(data)

    def _up(self, program: socket.socket, navd: socket.socket) -> None:
        pending = b""
        with contextlib.suppress(OSError):
            while data := program.recv(65536):
                navd.sendall(data)
                now = time.monotonic()
                pending += data
                *lines, pending = pending.split(b"\n")
                self.lines.extend((now, line) for line in lines)

    def scans(self, since: int = 1) -> list[tuple[float, float]]:
        """(arrival [s], its stamp [s]) of each scan among the lines from ``since`` on,
        decoded as navd does (the program stamps every scan)."""
        frames = [(at, decode_sensor("lidar", line)) for at, line in self.lines[max(since, 1) :]]
        return [
            (at, frame.stamp)
            for at, frame in frames
            if isinstance(frame, ScanFrame) and frame.stamp is not None
        ]

    def close(self) -> None:
        for sock in self._sockets:
            with contextlib.suppress(OSError):
                sock.close()


def _delivery(scans: list[tuple[float, float]], turns: list[list[float]]) -> dict[str, Any]:
    """[ms] from each turn's end to its scan's arrival, and the stamp's error."""
    delays, errors = [], []
    for arrived, stamp in scans:
        first, last = min(turns, key=lambda t: abs(t[0] - stamp))
        delays.append((arrived - last) * 1e3)
        errors.append((stamp - first) * 1e3)
    if not delays:
        return {}
    ordered = sorted(delays)
    return {
        "delivery_p50_ms": round(statistics.median(delays), 1),
        "delivery_p90_ms": round(ordered[int(0.9 * (len(ordered) - 1))], 1),
        "delivery_max_ms": round(ordered[-1], 1),
        "stamp_error_p50_ms": round(statistics.median(errors), 2),
        "stamp_error_max_abs_ms": round(max(abs(e) for e in errors), 2),
    }


def _log_has(path: Path, text: str) -> bool:
    return path.exists() and text in path.read_text(encoding="utf-8", errors="replace")


def _wait_for(predicate: Any, timeout_s: float, why: str) -> None:
    deadline = time.monotonic() + timeout_s
    while not predicate():
        if time.monotonic() > deadline:
            raise RuntimeError(why)
        time.sleep(0.05)


if os.name != "posix":  # pragma: no cover - pseudo-terminals
    raise ImportError("the lidar program benchmark needs pseudo-terminals (POSIX)")
