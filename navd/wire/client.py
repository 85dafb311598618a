"""navd's Python client: one connection to the daemon, blocking (``Client``) or asyncio
(``AsyncClient``), speaking typed frames.

The CLI's control commands, the simulator's sensors and clock, the benchmarks' sensor
programs and the tests all talk to navd through these two classes; docs/protocol.md shows
them as navd's Python API. Any other language can do the same in a few dozen lines.

    with Client("127.0.0.1", 7420) as navd:
        ack = navd.request(GoalFrame(x=2.0, y=1.5))
"""

from __future__ import annotations

import asyncio
import contextlib
import math
import socket
import time
from typing import TypeVar

from navd.wire.base import Frame, Hello, Role
from navd.wire.codec import decode_reply, encode
from navd.wire.errors import ClientError, ConnectionClosedError, RequestRefusedError, WireError
from navd.wire.replies import Ack, ErrorFrame, Reply, Welcome

__all__ = ["AsyncClient", "Client"]

R = TypeVar("R", bound=Reply)
READ_LIMIT_BYTES = 1 << 24  # longest reply line an AsyncClient reads (a status frame is ~4 KB)


def _hello(role: Role, device_id: str, token: str | None) -> bytes:
    return encode(Hello(role=role, device_id=device_id, token=token))


def _welcome(reply: Reply) -> Welcome:
    if isinstance(reply, Welcome):
        return reply
    if isinstance(reply, ErrorFrame):
        raise RequestRefusedError("connection", reply)
    raise ClientError(f"navd answered the hello with a {reply.type!r} frame")


def _decode(line: bytes) -> Reply | None:
    """The reply on ``line``; None for a kind of reply this client does not know (a newer
    daemon's: skipped, as the protocol promises old clients).

    Raises:
        ConnectionClosedError: the line is empty (navd closed the connection).
        ClientError: the line is not a reply at all.
    """
    if not line:
        raise ConnectionClosedError("navd closed the connection")
    try:
        return decode_reply(line)
    except WireError as err:
        if err.field == "type":
            return None
        raise ClientError(
            f"navd sent a line this client cannot read ({err}): {line[:200]!r}"
        ) from err


def _answer(reply: Reply, frame: Frame) -> Ack | None:
    """The ack of ``frame`` if ``reply`` is it; raises if ``reply`` refuses it.

    An error frame answers the oldest line not yet answered: send requests one at a time
    with ``request`` to know which one it refuses.
    """
    if isinstance(reply, ErrorFrame):
        raise RequestRefusedError(f"{frame.type} request", reply)
    if isinstance(reply, Ack) and reply.request == frame.type:
        return reply
    return None


class Client:
    """A blocking connection to navd, after a successful hello.

    Args:
        host, port: where navd listens.
        role: "control", a sensor kind ("lidar", "imu", "gps", "compass",
            "wheel_odometry"), or "clock".
        device_id: this client's name.
        token: the shared secret, when the daemon requires one.
        timeout_s: [s] longest wait for connecting and for each answer looked for (None: wait
            for ever). A connection that timed out is closed.

    Raises:
        ClientError: navd cannot be reached or refused the hello.
    """

    def __init__(
        self,
        host: str,
        port: int,
        *,
        role: Role = "control",
        device_id: str = "cli",
        token: str | None = None,
        timeout_s: float | None = 5.0,
    ) -> None:
        self.timeout_s = timeout_s
        try:
            self.sock = socket.create_connection((host, port), timeout=timeout_s)
        except OSError as err:
            raise ClientError(f"cannot reach navd at {host}:{port}: {err}") from err
        self.sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self._reader = self.sock.makefile("rb")
        try:
            self.sock.sendall(_hello(role, device_id, token))
            self.welcome = _welcome(self.receive())
        except BaseException:
            self.close()
            raise

    def send(self, frame: Frame) -> None:
        """Send one frame."""
        self.send_raw(encode(frame))

    def send_raw(self, data: bytes) -> None:
        """Send bytes as they are: encoded frames (a burst of them in one write), or, in
        tests, what a broken client would send."""
        self.sock.sendall(data)

    def receive(self) -> Reply:
        """The next frame from navd (kinds this client does not know are skipped).

        Raises:
            ConnectionClosedError: navd closed the connection.
            ClientError: nothing came in time, the connection broke, or a line that is not
                a reply.
        """
        while True:
            try:
                line = self._reader.readline()
            except TimeoutError as err:
                self.close()  # a timed-out socket file cannot be read again
                raise ClientError(f"navd did not answer within {self.timeout_s} s") from err
            except OSError as err:
                raise ConnectionClosedError(f"the connection to navd broke: {err}") from err
            reply = _decode(line)
            if reply is not None:
                return reply

    def receive_type(self, kind: type[R]) -> R:
        """The next frame of ``kind``, skipping others (status, goal progress), within
        ``timeout_s`` in all.

        Raises:
            ClientError: as for ``receive``, or none came in time.
        """
        deadline = self._deadline()
        while True:
            reply = self.receive()
            if isinstance(reply, kind):
                return reply
            self._check(deadline, kind.__name__)

    def request(self, frame: Frame) -> Ack:
        """Send a request and return its ack, skipping unrelated frames, within
        ``timeout_s`` in all.

        Raises:
            RequestRefusedError: navd answered with an error.
            ClientError: as for ``receive``, or no ack came in time.
        """
        self.send(frame)
        deadline = self._deadline()
        while True:
            ack = _answer(self.receive(), frame)
            if ack is not None:
                return ack
            self._check(deadline, f"ack of the {frame.type} request")

    def _deadline(self) -> float:
        return math.inf if self.timeout_s is None else time.monotonic() + self.timeout_s

    def _check(self, deadline: float, awaited: str) -> None:
        if time.monotonic() > deadline:
            raise ClientError(f"no {awaited} from navd within {self.timeout_s} s")

    def close(self) -> None:
        """Close the connection."""
        self._reader.close()
        self.sock.close()

    def __enter__(self) -> Client:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class AsyncClient:
    """An asyncio connection to navd: ``await AsyncClient.connect(...)`` says hello and
    returns once welcomed; ``open`` only connects (a test of the handshake says its own).

    Args:
        reader, writer: the open streams.
        welcome: navd's answer to the hello (None before it).
    """

    def __init__(
        self,
        reader: asyncio.StreamReader,
        writer: asyncio.StreamWriter,
        welcome: Welcome | None = None,
    ) -> None:
        self.reader = reader
        self.writer = writer
        self.welcome = welcome

    @classmethod
    async def open(cls, host: str, port: int, *, ready_timeout_s: float = 0.0) -> AsyncClient:
        """A connection that has said nothing yet.

        Args:
            ready_timeout_s: [s] keep trying this long while nobody listens yet (a daemon
                still starting).

        Raises:
            ClientError: nobody listened in time.
        """
        deadline = time.monotonic() + ready_timeout_s
        while True:
            try:
                reader, writer = await asyncio.open_connection(host, port, limit=READ_LIMIT_BYTES)
            except OSError as err:
                if time.monotonic() >= deadline:
                    raise ClientError(f"cannot reach navd at {host}:{port}: {err}") from err
                await asyncio.sleep(0.1)
                continue
            return cls(reader, writer)

    @classmethod
    async def connect(
        cls,
        host: str,
        port: int,
        *,
        role: Role = "control",
        device_id: str = "client",
        token: str | None = None,
        timeout_s: float = 5.0,
        ready_timeout_s: float = 0.0,
    ) -> AsyncClient:
        """Connect and say hello.

        Args:
            host, port, role, device_id, token: as for ``Client``.
            timeout_s: [s] time navd has to answer the hello.
            ready_timeout_s: [s] keep trying this long while nobody listens yet.

        Raises:
            ClientError: navd cannot be reached, refused the hello, or did not answer it.
        """
        client = await cls.open(host, port, ready_timeout_s=ready_timeout_s)
        client.send_raw(_hello(role, device_id, token))
        try:
            client.welcome = _welcome(await client.receive(timeout_s))
        except BaseException as err:
            client.writer.close()
            if isinstance(err, TimeoutError):
                raise ClientError(f"navd did not answer the hello within {timeout_s} s") from err
            raise
        return client

    def send(self, frame: Frame) -> None:
        """Queue one frame (``drain`` waits until the kernel took it)."""
        self.writer.write(encode(frame))

    def send_raw(self, data: bytes) -> None:
        """Queue bytes as they are (encoded frames, or a broken client's bytes in tests)."""
        self.writer.write(data)

    async def drain(self) -> None:
        """Wait until the queued bytes are handed to the kernel."""
        await self.writer.drain()

    async def receive(self, timeout_s: float = 5.0) -> Reply:
        """The next frame from navd.

        Raises:
            TimeoutError: nothing came within ``timeout_s``.
            ConnectionClosedError: navd closed the connection.
        """

        async def next_known() -> Reply:
            while (reply := _decode(await self.reader.readline())) is None:
                pass
            return reply

        return await asyncio.wait_for(next_known(), timeout_s)

    async def receive_type(self, kind: type[R], timeout_s: float = 5.0) -> R:
        """The next frame of ``kind`` within ``timeout_s`` [s], skipping others.

        Raises:
            TimeoutError, ConnectionClosedError: as for ``receive``.
        """

        async def find() -> R:
            while True:
                reply = _decode(await self.reader.readline())
                if isinstance(reply, kind):
                    return reply  # (None, an unknown kind, never is)

        return await asyncio.wait_for(find(), timeout_s)

    async def request(self, frame: Frame, timeout_s: float = 10.0) -> Ack:
        """Send a request and wait for its ack, skipping unrelated frames.

        Raises:
            RequestRefusedError: navd answered with an error.
            TimeoutError: no ack within ``timeout_s``.
        """
        self.send(frame)

        async def find() -> Ack:
            while True:
                reply = _decode(await self.reader.readline())
                ack = None if reply is None else _answer(reply, frame)
                if ack is not None:
                    return ack

        return await asyncio.wait_for(find(), timeout_s)

    async def close(self) -> None:
        """Close the connection."""
        self.writer.close()
        with contextlib.suppress(ConnectionError):
            await self.writer.wait_closed()
