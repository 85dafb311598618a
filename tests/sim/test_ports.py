"""Free ports for daemons started beside others: never one in use, and out of the way of
the ports the system hands out by itself."""

from __future__ import annotations

import socket
from pathlib import Path

import pytest

from navd.sim import ports


def _listen(port: int) -> socket.socket:
    server = socket.socket()
    server.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    server.bind(("127.0.0.1", port))
    server.listen()
    return server


def test_a_free_port_lies_below_the_ephemeral_range_and_can_be_listened_on() -> None:
    first = ports._first_ephemeral_port()
    if first is None or first - ports.LOWEST_PORT < ports.MIN_SPAN:
        pytest.skip("this system has no room below its ephemeral port range")
    for _ in range(20):
        port = ports.free_port()
        assert ports.LOWEST_PORT <= port < first
        _listen(port).close()


class _Scripted:
    """Choices that come in a given order."""

    def __init__(self, *picks: int) -> None:
        self.picks = list(picks)

    def randrange(self, low: int, high: int) -> int:
        pick = self.picks.pop(0)
        assert low <= pick < high
        return pick


def test_a_port_something_holds_is_passed_over(monkeypatch: pytest.MonkeyPatch) -> None:
    first = ports._first_ephemeral_port()
    if first is None or first - ports.LOWEST_PORT < ports.MIN_SPAN:
        pytest.skip("this system has no room below its ephemeral port range")
    held = _listen(0)  # a port the system gave: above LOWEST_PORT, and held
    client = socket.create_connection(held.getsockname())  # its own port is held too
    listened, connected = held.getsockname()[1], client.getsockname()[1]
    try:
        free = ports.LOWEST_PORT
        while not ports._unused(free):
            free += 1
        monkeypatch.setattr(
            ports, "_first_ephemeral_port", lambda: max(listened, connected, free) + 1
        )
        monkeypatch.setattr(ports, "_choices", _Scripted(listened, connected, free))
        assert ports.free_port() == free
    finally:
        client.close()
        held.close()


def test_without_a_known_ephemeral_range_the_system_picks(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    monkeypatch.setattr(ports, "EPHEMERAL_RANGE_FILE", tmp_path / "absent")
    monkeypatch.setattr(ports, "_choices", _Scripted())  # would fail if asked
    port = ports.free_port()
    _listen(port).close()
