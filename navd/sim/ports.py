"""A free TCP port on loopback, for a daemon, a broker or a view started beside others."""

from __future__ import annotations

import socket

__all__ = ["free_port", "port_taken"]


def free_port() -> int:
    """A TCP port nobody listens on now on 127.0.0.1 (the system picks it; another process
    could take it before the caller binds it, which a caller that binds at once never saw)."""
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
