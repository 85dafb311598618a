"""Helpers to run the real navd process and read its JSON log lines."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from queue import Empty, Queue
from typing import Any

import pytest

from navd.config import NavdConfig
from navd.sim import free_port

REPO = Path(__file__).resolve().parents[2]
# [s] the most a daemon process may take to start: imports and kernels from the cache take
# about a second on an idle machine and many on a busy one; waited for as an event
READY_S = 60.0
STOP_S = 20.0  # [s] the most a signalled daemon may take to exit (its budget is 10 s)


def run_navd(*args: str, timeout_s: float = 30.0) -> subprocess.CompletedProcess[str]:
    """Run one ``navd`` command to completion (the real CLI, as a user types it)."""
    return subprocess.run(
        [sys.executable, "-m", "navd", *args],
        cwd=REPO,
        capture_output=True,
        text=True,
        timeout=timeout_s,
        check=False,
    )


class DaemonProcess:
    """The real ``navd run`` process, with its JSON log lines collected by a thread."""

    def __init__(self, args: list[str], env: dict[str, str] | None = None) -> None:
        env = dict(os.environ, PYTHONUNBUFFERED="1", **(env or {}))
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "navd", *args],
            cwd=REPO,
            env=env,
            stdin=subprocess.DEVNULL,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        self.lines: Queue[dict[str, Any]] = Queue()
        self.seen: list[dict[str, Any]] = []
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self) -> None:
        assert self.proc.stderr is not None
        for raw in self.proc.stderr:
            try:
                self.lines.put(json.loads(raw))
            except json.JSONDecodeError:
                self.lines.put({"event": "non-json", "raw": raw})

    def wait_for(self, event: str, timeout_s: float) -> dict[str, Any]:
        """The first log line whose event is ``event``, waiting up to ``timeout_s``."""
        deadline = time.monotonic() + timeout_s
        while True:
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                raise AssertionError(f"no {event!r} log line within {timeout_s} s; saw {self.seen}")
            try:
                line = self.lines.get(timeout=remaining)
            except Empty:
                continue
            self.seen.append(line)
            if line.get("event") == event:
                return line

    def drain(self) -> list[dict[str, Any]]:
        """Every log line that came and was not read yet."""
        lines = []
        while True:
            try:
                lines.append(self.lines.get_nowait())
            except Empty:
                self.seen.extend(lines)
                return lines

    def stop(self) -> None:
        if self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait(5)


@pytest.fixture
def spawn_daemon() -> Iterator[Any]:
    started: list[DaemonProcess] = []

    def spawn(*args: str, env: dict[str, str] | None = None) -> DaemonProcess:
        daemon = DaemonProcess(list(args), env)
        started.append(daemon)
        return daemon

    yield spawn
    for daemon in started:
        daemon.stop()


def default_config(folder: Path) -> Path:
    """The shipped config/navd.toml with only the ports (TCP, live view, page) changed to free
    ones, so the test runs on the defaults and never meets a navd running on the defaults."""
    text = (REPO / "config" / "navd.toml").read_text(encoding="utf-8")
    defaults = NavdConfig()
    ports = (
        ("tcp", "port", defaults.tcp.port),
        ("live view", "port", defaults.viz.port),
        ("operator page", "page_port", defaults.viz.page_port),
    )
    for what, key, port in ports:
        line = f"\n{key} = {port}\n"
        assert text.count(line) == 1, f"config/navd.toml lost its {what} port line"
        text = text.replace(line, f"\n{key} = {free_port()}\n")
    path = folder / "navd.toml"
    path.write_text(text)
    return path


@pytest.fixture
def daemon_on_port(spawn_daemon: Any, tmp_path: Path) -> Any:
    """Start the real daemon with extra TOML; returns (process, port) once it is ready."""

    def start(extra_toml: str = "") -> tuple[DaemonProcess, int]:
        port = free_port()
        path = tmp_path / "navd.toml"
        # The live view on a port of its own too (unless the test sets its section).
        view = "" if "[viz]" in extra_toml else "\n[viz]\nport = 0\npage_port = 0\n"
        path.write_text(f"[tcp]\nport = {port}\n{extra_toml}{view}")
        daemon: DaemonProcess = spawn_daemon("run", "--config", str(path))
        daemon.wait_for("ready", timeout_s=READY_S)
        return daemon, port

    return start
