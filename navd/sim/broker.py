"""A local MQTT broker for simulated fleets and benchmarks: mosquitto (the broker users
deploy) on a free port of 127.0.0.1, in a folder of its own; started, killed and restarted
by its owner."""

from __future__ import annotations

import getpass
import shutil
import socket
import subprocess
import time
from pathlib import Path

from navd.sim.errors import SimError
from navd.sim.ports import free_port

__all__ = ["LocalBroker", "mosquitto_path"]


def mosquitto_path() -> str | None:
    """The mosquitto binary, or None when it is not installed."""
    found = shutil.which("mosquitto")
    if found is None and Path("/usr/sbin/mosquitto").is_file():
        found = "/usr/sbin/mosquitto"
    return found


class LocalBroker:
    """mosquitto listening on 127.0.0.1:``port`` (anonymous, no persistence).

    Raises:
        SimError: mosquitto is not installed.
    """

    def __init__(self, folder: Path) -> None:
        binary = mosquitto_path()
        if binary is None:
            raise SimError("mosquitto is not installed (apt-get install mosquitto)")
        self.binary = binary
        self.port = free_port()
        self.config = folder / "mosquitto.conf"
        self.config.write_text(
            # run as whoever started it (as root mosquitto would become "mosquitto" and lose
            # its own folder: the log, certificates, password file)
            f"user {getpass.getuser()}\n"
            f"listener {self.port} 127.0.0.1\nallow_anonymous true\npersistence false\n"
            f"log_dest file {folder / 'mosquitto.log'}\n",
            encoding="utf-8",
        )
        self.process: subprocess.Popen[bytes] | None = None

    @property
    def url(self) -> str:
        return f"mqtt://127.0.0.1:{self.port}"

    def start(self, timeout_s: float = 10.0) -> None:
        """Start it and wait until it listens.

        Raises:
            SimError: it did not listen within ``timeout_s``.
        """
        self.process = subprocess.Popen(
            [self.binary, "-c", str(self.config)],
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            try:
                with socket.create_connection(("127.0.0.1", self.port), timeout=0.2):
                    return
            except OSError:
                time.sleep(0.05)
        self.stop()
        raise SimError(f"mosquitto did not listen on port {self.port} within {timeout_s} s")

    def kill(self) -> None:
        """Kill it at once (SIGKILL: no goodbye to anyone)."""
        if self.process is not None:
            self.process.kill()
            self.process.wait(5.0)
            self.process = None

    def stop(self) -> None:
        """Stop it (SIGTERM, then SIGKILL after 5 s)."""
        if self.process is not None:
            self.process.terminate()
            try:
                self.process.wait(5.0)
            except subprocess.TimeoutExpired:
                self.process.kill()
            self.process = None
