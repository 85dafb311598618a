"""The simulator's links to the daemon: the chassis on a pseudo-terminal, and the sensors and
the clock as TCP clients, exactly like hardware and sensor programs.
"""

from __future__ import annotations

import asyncio
import contextlib
import os
import tty
from pathlib import Path

from navd.sim.errors import SimError
from navd.sim.settings import SimSettings
from navd.wire import AsyncClient, ClientError, Role

__all__ = ["RECONNECT_S", "PtyChassis", "SensorLinks"]

HELLO_TIMEOUT_S = 5.0
RECONNECT_S = 0.2  # [s] between attempts to reach a daemon that is not there (yet)


class PtyChassis:
    """The chassis end of a pseudo-terminal; the daemon opens the other end through a
    symlink at ``link`` as it would /dev/ttyS0. Bytes pass unchanged both ways.

    Args:
        link: where the symlink to the daemon's end goes.
    """

    def __init__(self, link: Path) -> None:
        self.link = link
        self.fd = -1
        self._slave = -1

    def open(self) -> None:
        """Create the pseudo-terminal and its link.

        Raises:
            SimError: the link cannot be made.
        """
        self.fd, self._slave = os.openpty()
        tty.setraw(self._slave)  # bytes pass unchanged in both directions
        os.set_blocking(self.fd, False)
        with contextlib.suppress(FileNotFoundError):
            self.link.unlink()
        try:
            self.link.symlink_to(os.ttyname(self._slave))
        except OSError as err:
            raise SimError(f"cannot create the chassis link {self.link}: {err}") from err

    def close(self) -> None:
        """Remove the link and close both ends."""
        with contextlib.suppress(FileNotFoundError):
            self.link.unlink()
        for fd in (self.fd, self._slave):
            with contextlib.suppress(OSError):
                os.close(fd)

    def read(self) -> bytes:
        """What the daemon wrote and is waiting (b"" when nothing is)."""
        chunks = []
        with contextlib.suppress(BlockingIOError, OSError):
            while data := os.read(self.fd, 4096):
                chunks.append(data)
        return b"".join(chunks)

    def write(self, data: bytes) -> None:
        """Send bytes to the daemon (an encoder line); dropped if nobody can take them."""
        with contextlib.suppress(BlockingIOError, OSError):
            os.write(self.fd, data)


class SensorLinks:
    """The simulator's TCP connections to the daemon, each after a welcome; what the daemon
    sends back on them is read and dropped (it counts its own errors).

    Args:
        settings: where the daemon listens, and its token.
    """

    def __init__(self, settings: SimSettings) -> None:
        self.settings = settings
        self.connected: set[str] = set()
        self.welcomed: set[str] = set()  # every device the daemon ever welcomed
        self.last_refusal = ""  # why the last attempt failed (the daemon is not there...)
        self._readers: set[asyncio.Task[None]] = set()

    async def open(self, role: Role, device_id: str) -> AsyncClient:
        """One connection with a completed hello.

        Raises:
            ClientError: the daemon is not there or did not welcome us.
        """
        s = self.settings
        client = await AsyncClient.connect(
            s.host, s.port, role=role, device_id=device_id, token=s.token, timeout_s=HELLO_TIMEOUT_S
        )
        self.connected.add(device_id)
        self.welcomed.add(device_id)
        return client

    async def open_sensor(self, role: Role, device_id: str) -> AsyncClient:
        """A sensor connection whose replies are read and dropped."""
        client = await self.open(role, device_id)
        task = asyncio.get_running_loop().create_task(_drain(client.reader))
        self._readers.add(task)
        task.add_done_callback(self._readers.discard)
        return client

    async def keep_trying(self, role: Role, device_id: str, retry_s: float) -> AsyncClient:
        """A sensor connection, retried every ``retry_s`` [s] until the daemon welcomes it
        (a daemon still starting, or restarting)."""
        while True:
            try:
                return await self.open_sensor(role, device_id)
            except (ClientError, OSError) as err:
                self.last_refusal = str(err) or type(err).__name__
                await asyncio.sleep(retry_s)

    def closed(self, device_id: str) -> None:
        """The connection of ``device_id`` ended."""
        self.connected.discard(device_id)


async def _drain(reader: asyncio.StreamReader) -> None:
    """Read and drop what the daemon sends a sensor (errors are counted by the daemon)."""
    with contextlib.suppress(ConnectionError, OSError):
        while await reader.readline():
            pass
