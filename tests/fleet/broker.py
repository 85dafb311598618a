"""A real MQTT broker for tests: mosquitto on a free port of this machine, in a temp folder,
started and stopped (and killed and started again) by the test. Tests skip, saying why, where
mosquitto is not installed (the set-up installs it where it can: root with apt)."""

from __future__ import annotations

import shutil
import socket
import subprocess
import time
from pathlib import Path

import pytest

from navd.sim.session import free_port


def mosquitto_path() -> str:
    """The mosquitto binary, or a skip saying how to get it."""
    found = shutil.which("mosquitto") or (
        "/usr/sbin/mosquitto" if Path("/usr/sbin/mosquitto").is_file() else None
    )
    if found is None:
        pytest.skip(
            "mosquitto is not installed (apt-get install mosquitto; `make test` does as root)"
        )
    return found


class Broker:
    """mosquitto listening on 127.0.0.1:``port`` (anonymous, no persistence)."""

    def __init__(self, folder: Path) -> None:
        self.binary = mosquitto_path()
        self.port = free_port()
        self.config = folder / "mosquitto.conf"
        self.config.write_text(
            f"listener {self.port} 127.0.0.1\nallow_anonymous true\npersistence false\n"
            f"log_dest file {folder / 'mosquitto.log'}\n",
            encoding="utf-8",
        )
        self.process: subprocess.Popen[bytes] | None = None

    @property
    def url(self) -> str:
        return f"mqtt://127.0.0.1:{self.port}"

    def start(self) -> None:
        """Start it and wait until it listens."""
        self.process = subprocess.Popen(
            [self.binary, "-c", str(self.config)],
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
        deadline = time.monotonic() + 10.0
        while time.monotonic() < deadline:
            try:
                with socket.create_connection(("127.0.0.1", self.port), timeout=0.2):
                    return
            except OSError:
                time.sleep(0.05)
        raise AssertionError(f"mosquitto did not listen on port {self.port}")

    def kill(self) -> None:
        """Kill it at once (SIGKILL: no goodbye to anyone)."""
        if self.process is not None:
            self.process.kill()
            self.process.wait(5.0)
            self.process = None

    def stop(self) -> None:
        if self.process is not None:
            self.process.terminate()
            try:
                self.process.wait(5.0)
            except subprocess.TimeoutExpired:
                self.process.kill()
            self.process = None
