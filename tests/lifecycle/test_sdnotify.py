from __future__ import annotations

import asyncio
import os
import socket
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from navd.config import parse_config
from navd.lifecycle.daemon import Daemon
from navd.lifecycle.sdnotify import SystemdNotifier


class NotifyListener:
    """A unix datagram socket standing in for systemd; timestamps what arrives."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.sock = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
        self.sock.bind(str(path))
        self.sock.settimeout(0.1)
        self.received: list[tuple[float, str]] = []
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self) -> None:
        while not self._stop.is_set():
            try:
                data = self.sock.recv(4096)
            except TimeoutError:
                continue
            self.received.append((time.monotonic(), data.decode()))

    def lines(self) -> list[str]:
        return [text for _, text in self.received]

    def wait_for(self, prefix: str, timeout_s: float = 3.0) -> str:
        """The first datagram starting with ``prefix``, waiting for it to arrive."""
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            for text in self.lines():
                if text.startswith(prefix):
                    return text
            time.sleep(0.01)
        raise AssertionError(f"no {prefix!r} datagram within {timeout_s} s: {self.lines()}")

    def close(self) -> None:
        self._stop.set()
        self._thread.join()
        self.sock.close()


@pytest.fixture
def listener(tmp_path: Path) -> Iterator[NotifyListener]:
    listener = NotifyListener(tmp_path / "notify")
    yield listener
    listener.close()


def test_without_notify_socket_nothing_is_sent() -> None:
    notifier = SystemdNotifier({})
    assert not notifier.enabled and notifier.watchdog_period_s is None
    assert notifier.notify("READY=1") is False


@pytest.mark.parametrize(
    ("env", "period"),
    [
        ({"WATCHDOG_USEC": "5000000"}, 5.0),
        ({"WATCHDOG_USEC": "5000000", "WATCHDOG_PID": str(os.getpid())}, 5.0),
        ({"WATCHDOG_USEC": "5000000", "WATCHDOG_PID": "1"}, None),  # for another process
        ({"WATCHDOG_USEC": "soon"}, None),
        ({"WATCHDOG_USEC": "0"}, None),
        ({}, None),
    ],
)
def test_watchdog_period(env: dict[str, str], period: float | None) -> None:
    assert SystemdNotifier(env).watchdog_period_s == period


def test_sends_lines_in_one_datagram(listener: NotifyListener) -> None:
    notifier = SystemdNotifier({"NOTIFY_SOCKET": str(listener.path)})
    assert notifier.notify("READY=1", "STATUS=running")
    listener.wait_for("READY=1")
    assert listener.lines() == ["READY=1\nSTATUS=running"]
    notifier.close()


def test_abstract_namespace_address() -> None:
    name = f"navd-test-{os.getpid()}"
    server = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
    server.bind("\0" + name)
    server.settimeout(2.0)
    try:
        assert SystemdNotifier({"NOTIFY_SOCKET": "@" + name}).notify("READY=1")
        assert server.recv(100) == b"READY=1"
    finally:
        server.close()


async def test_watchdog_pings_stop_while_the_loop_is_stalled(listener: NotifyListener) -> None:
    notifier = SystemdNotifier({"NOTIFY_SOCKET": str(listener.path), "WATCHDOG_USEC": "100000"})
    daemon = Daemon(parse_config({}), handle_signals=False, notifier=notifier)
    task = asyncio.create_task(daemon.run())
    await daemon.ready.wait()
    await asyncio.sleep(0.3)
    stall_start = time.monotonic()
    time.sleep(0.6)  # a handler gone wrong: the loop does nothing else for 0.6 s
    stall_end = time.monotonic()
    await asyncio.sleep(0.3)
    daemon.request_shutdown("test over")
    await task
    listener.wait_for("STOPPING=1")
    pings = [t for t, text in listener.received if text == "WATCHDOG=1"]
    assert "READY=1\nSTATUS=running" in listener.lines()
    before = [t for t in pings if t < stall_start]
    during = [t for t in pings if stall_start + 0.01 < t < stall_end]
    after = [t for t in pings if t > stall_end]
    assert len(before) >= 4  # every 50 ms
    assert during == []
    assert len(after) >= 2
    assert sum(line.startswith("STOPPING=1") for line in listener.lines()) == 1
