"""A small blocking client of the wire protocol, for the ``navd goal/cancel/status`` commands,
tests and benchmarks. Any language can do the same in a few dozen lines (docs/protocol.md)."""

from __future__ import annotations

import json
import socket
from typing import Any

from navd.drivers.errors import DriverError
from navd.drivers.wire import PROTOCOL_VERSION

__all__ = ["Client", "ClientError"]


class ClientError(DriverError):
    """The daemon refused the connection or a request, or could not be reached."""


class Client:
    """One connection to navd, after a successful hello.

    Args:
        host, port: where navd listens.
        role: "control" or a sensor kind.
        device_id: this client's name.
        token: the shared secret, when the daemon requires one.
        timeout_s: [s] socket timeout for connecting and reading.
    """

    def __init__(
        self,
        host: str,
        port: int,
        *,
        role: str = "control",
        device_id: str = "cli",
        token: str | None = None,
        timeout_s: float = 5.0,
    ) -> None:
        try:
            self.sock = socket.create_connection((host, port), timeout=timeout_s)
        except OSError as err:
            raise ClientError(f"cannot reach navd at {host}:{port}: {err}") from err
        self.sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self._reader = self.sock.makefile("rb")
        hello: dict[str, Any] = {
            "type": "hello",
            "protocol": PROTOCOL_VERSION,
            "role": role,
            "device_id": device_id,
        }
        if token is not None:
            hello["token"] = token
        self.send(hello)
        welcome = self.receive()
        if welcome.get("type") != "welcome":
            self.close()
            raise ClientError(f"navd refused the connection: {_reason(welcome)}")
        self.welcome = welcome

    def send(self, frame: dict[str, Any]) -> None:
        """Send one frame."""
        self.sock.sendall(json.dumps(frame, separators=(",", ":")).encode() + b"\n")

    def receive(self) -> dict[str, Any]:
        """The next frame from navd.

        Raises:
            ClientError: the connection closed or timed out.
        """
        try:
            line = self._reader.readline()
        except TimeoutError as err:
            raise ClientError("navd did not answer in time") from err
        if not line:
            raise ClientError("navd closed the connection")
        frame: dict[str, Any] = json.loads(line)
        return frame

    def request(self, frame: dict[str, Any]) -> dict[str, Any]:
        """Send a request and return its ack, skipping unrelated frames (status, goal_status).

        Raises:
            ClientError: navd answered with an error.
        """
        self.send(frame)
        while True:
            answer = self.receive()
            if answer.get("type") == "error":
                raise ClientError(_reason(answer))
            if answer.get("type") == "ack" and answer.get("request") == frame["type"]:
                return answer

    def close(self) -> None:
        self._reader.close()
        self.sock.close()

    def __enter__(self) -> Client:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _reason(frame: dict[str, Any]) -> str:
    if frame.get("type") == "error":
        field = frame.get("field")
        return f"{field}: {frame.get('reason')}" if field else str(frame.get("reason"))
    return f"unexpected frame {frame}"
