"""A sensor program's connections to navd: one for its kind's role, under its device id,
and one more for each other role its device's frames belong to (an MCU's bumpers, range
sensors and battery), under the device id with the role after it (``mcu0-range``), opened
when the first such frame comes."""

from __future__ import annotations

import contextlib

from navd.sensors.link import Link
from navd.wire import ALSO_SENT, SENSOR_FRAMES, Client, Role, SensorFrame

__all__ = ["Connections", "role_of"]

_ROLE_OF_FRAME = {frame: role for role, frame in SENSOR_FRAMES.items()}


def role_of(frame: SensorFrame, main: Role) -> Role:
    """The role ``frame`` goes under: the program's own where that role sends it (a gps
    connection's heading too), else the frame's own role."""
    kind = type(frame)
    if kind is SENSOR_FRAMES.get(main) or kind in ALSO_SENT.get(main, ()):
        return main
    return _ROLE_OF_FRAME[kind]  # type: ignore[return-value]


class Connections:
    """The program's clients, by role.

    Args:
        link: where navd is, the device id and the token.
        main: the kind's own role (connected first, before any frame).
    """

    def __init__(self, link: Link, main: Role) -> None:
        self.link, self.main = link, main
        self.clients: dict[Role, Client] = {}

    def device_id(self, role: Role) -> str:
        """The id ``role``'s connection says in its hello."""
        return self.link.device_id if role == self.main else f"{self.link.device_id}-{role}"

    def open(self, role: Role) -> Client:
        """``role``'s client, connected if it is not.

        Raises:
            ClientError: navd is not there, or refused the hello.
        """
        client = self.clients.get(role)
        if client is None:
            link = self.link
            client = Client(
                link.host,
                link.navd_port,
                role=role,
                device_id=self.device_id(role),
                token=link.token,
            )
            self.clients[role] = client
        return client

    @property
    def connected(self) -> bool:
        """Whether the main connection is up."""
        return self.main in self.clients

    def send(self, frames: list[SensorFrame]) -> None:
        """Send each frame on its role's connection.

        Raises:
            ClientError: a connection could not be opened.
            OSError: a connection broke (all are closed: they are opened again).
        """
        for frame in frames:
            self.open(role_of(frame, self.main)).send(frame)

    def close(self) -> None:
        for client in self.clients.values():
            with contextlib.suppress(OSError):
                client.close()
        self.clients.clear()
