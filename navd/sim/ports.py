"""A free TCP port on loopback, for a daemon, a broker or a view started beside others.

A port the system hands out for ``bind(0)`` comes from its ephemeral range, which every
outgoing connection and every other ``bind(0)`` draws from too: in the time between choosing
it and the daemon binding it, something else may take it (a test suite opens thousands of
connections). So the port is chosen below that range, where the system never hands ports out
by itself; each process tries its own sequence, so two processes seldom try the same one."""

from __future__ import annotations

import os
import random
import socket
from pathlib import Path

__all__ = ["free_port", "port_taken"]

EPHEMERAL_RANGE_FILE = Path("/proc/sys/net/ipv4/ip_local_port_range")
LOWEST_PORT = 10000  # below it, well-known and registered services crowd
MIN_SPAN = 1000  # ports below the ephemeral range needed to choose there
TRIES = 50  # ports tried there before asking the system for one

_choices = random.Random(os.getpid())  # each process its own sequence


def free_port() -> int:
    """A TCP port nobody uses now on 127.0.0.1, chosen below the system's ephemeral range
    where one exists (see the module docstring), else one the system picks."""
    first_ephemeral = _first_ephemeral_port()
    if first_ephemeral is not None and first_ephemeral - LOWEST_PORT >= MIN_SPAN:
        for _ in range(TRIES):
            port = _choices.randrange(LOWEST_PORT, first_ephemeral)
            if _unused(port):
                return port
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return int(sock.getsockname()[1])


def port_taken(port: int) -> str | None:
    """Why ``port`` cannot be listened on at 127.0.0.1 (the system's words), or None. As
    navd's servers bind (address reuse on), a port a closed connection still holds in
    TIME_WAIT is free; one something listens on is not."""
    with socket.socket() as sock:
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            sock.bind(("127.0.0.1", port))
        except OSError as err:
            return err.strerror or str(err)
    return None


def _unused(port: int) -> bool:
    """Whether nothing holds ``port`` at all (bound without address reuse, so a port in
    TIME_WAIT counts as held too: a server without reuse could not take it)."""
    with socket.socket() as sock:
        try:
            sock.bind(("127.0.0.1", port))
        except OSError:
            return False
    return True


def _first_ephemeral_port() -> int | None:
    """The lowest port of the system's ephemeral range (Linux), None where unknown."""
    try:
        return int(EPHEMERAL_RANGE_FILE.read_text().split()[0])
    except (OSError, ValueError, IndexError):
        return None
