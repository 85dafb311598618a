"""The live view's public port: a gate in front of the Foxglove SDK's WebSocket server, which
listens on loopback only.

The SDK's server keeps, for each viewer, a queue of up to ``message_backlog_size`` messages,
each a copy: 50 viewers that do not read a 2000² map (4 MB a frame) held 190 MB more every
second. It has no connection cap and no deadline for the opening handshake. The gate adds
what it lacks, passing bytes through unchanged (the WebSocket protocol end to end is the
SDK's):

- at most ``max_viewers`` connections; one more is answered 503, naming the setting;
- the opening request whole within ``HANDSHAKE_DEADLINE_S`` of connecting, at most
  ``MAX_REQUEST_BYTES``;
- viewers that ask for the protocol by its earlier name (``foxglove.websocket.v1``) let in;
- at most ``buffer_bytes`` waiting for one viewer: a viewer that falls that far behind is
  disconnected (its viewer reconnects and starts from the latest state), so memory is
  bounded by max_viewers x buffer_bytes, never by how long a viewer stalls. The gate reads
  the SDK at once, so the SDK's queues stay empty.

It runs on the event loop with asyncio's protocols: each chunk is one callback and a copy
into the socket.
"""

from __future__ import annotations

import asyncio
import contextlib
from dataclasses import dataclass
from typing import Any

import foxglove
from foxglove.websocket import WebSocketServer

__all__ = [
    "HANDSHAKE_DEADLINE_S",
    "MAX_REQUEST_BYTES",
    "SDK_BACKLOG_MESSAGES",
    "GateLimits",
    "ViewerGate",
    "serve_viewers",
]

HANDSHAKE_DEADLINE_S = 5.0  # [s] from connecting to the end of the opening request
MAX_REQUEST_BYTES = 16_384  # the opening request's most (a browser's is under 2 KB)
REFUSED_LINGER_S = 0.5  # [s] a refused viewer's connection stays to take its request
UPSTREAM_HIGH_BYTES = 1_048_576  # a viewer's commands waiting for the SDK before it is paused
SDK_BACKLOG_MESSAGES = 64  # the SDK's own queue per viewer (the gate reads it at once)
SDK_PROTOCOL = b"foxglove.sdk.v1"
LEGACY_PROTOCOL = b"foxglove.websocket.v1"  # the same protocol's earlier name


@dataclass(frozen=True, slots=True)
class GateLimits:
    """How many viewers, and how far behind each may fall.

    Attributes:
        max_viewers: connections at once (the page's included).
        buffer_bytes: [bytes] the most waiting for one viewer before it is disconnected.
    """

    max_viewers: int
    buffer_bytes: int


class ViewerGate:
    """Listens for viewers and passes each on to the SDK's server on ``upstream_port``.

    Args:
        upstream_port: the SDK's server, on 127.0.0.1.
        limits: returns the limits in force (read at each new viewer).
        log: the view's logger (structlog-like).
    """

    def __init__(self, upstream_port: int, limits: Any, log: Any) -> None:
        self.upstream_port = upstream_port
        self._limits = limits
        self.log = log
        self.viewers: set[_Viewer] = set()
        self.refused = 0
        self.dropped = 0
        self._server: asyncio.Server | None = None

    async def listen(self, host: str, port: int) -> None:
        """Open the public port.

        Raises:
            OSError: the address cannot be bound.
        """
        loop = asyncio.get_running_loop()
        self._server = await loop.create_server(
            lambda: _Viewer(self), host=host, port=port, reuse_address=True
        )

    @property
    def port(self) -> int:
        assert self._server is not None, "not listening"
        port: int = self._server.sockets[0].getsockname()[1]
        return port

    @property
    def limits(self) -> GateLimits:
        limits: GateLimits = self._limits()
        return limits

    def close(self) -> None:
        """Stop listening and close every viewer."""
        if self._server is not None:
            self._server.close()
            self._server = None
        for viewer in list(self.viewers):
            viewer.close()

    def refuse(self, viewer: _Viewer) -> None:
        self.refused += 1
        if self.refused == 1 or self.refused % 100 == 0:
            self.log.warning(
                "viewer_refused",
                peer=viewer.peer,
                refused=self.refused,
                max_viewers=self.limits.max_viewers,
            )

    def drop_slow(self, viewer: _Viewer, waiting: int) -> None:
        self.dropped += 1
        self.log.warning(
            "viewer_dropped",
            peer=viewer.peer,
            waiting_bytes=waiting,
            limit_bytes=self.limits.buffer_bytes,
            reason="the viewer reads slower than the view sends (viz.viewer_buffer_bytes); it "
            "may reconnect",
        )


class _Viewer(asyncio.Protocol):
    """One viewer's connection, and its connection to the SDK's server."""

    def __init__(self, gate: ViewerGate) -> None:
        self.gate = gate
        self.transport: asyncio.Transport | None = None
        self.upstream: _Upstream | None = None
        self.peer = "?"
        self._early = bytearray()  # what the viewer sent before the SDK's end was open
        self._head = bytearray()  # the opening request so far
        self._requested = False  # the opening request is whole
        self.legacy = False  # the viewer asked for foxglove.websocket.v1 (answered as such)
        self._deadline: asyncio.TimerHandle | None = None
        self._closed = False

    def connection_made(self, transport: Any) -> None:
        self.transport = transport
        peer = transport.get_extra_info("peername")
        self.peer = f"{peer[0]}:{peer[1]}" if peer else "?"
        limits = self.gate.limits
        if len(self.gate.viewers) >= limits.max_viewers:
            body = (
                f"navd: {limits.max_viewers} viewers are connected (viz.max_viewers); close "
                "one, or raise the limit\n"
            ).encode()
            transport.write(
                b"HTTP/1.1 503 Service Unavailable\r\nConnection: close\r\n"
                b"Content-Type: text/plain; charset=utf-8\r\n"
                + f"Content-Length: {len(body)}\r\n\r\n".encode()
                + body
            )
            # its request is read and dropped until the close, so the close is a FIN after
            # the answer, not a reset that may take the answer with it
            if transport.can_write_eof():
                transport.write_eof()
            asyncio.get_running_loop().call_later(REFUSED_LINGER_S, transport.close)
            self._closed = True
            self.gate.refuse(self)
            return
        self.gate.viewers.add(self)
        transport.set_write_buffer_limits(high=limits.buffer_bytes)
        loop = asyncio.get_running_loop()
        self._deadline = loop.call_later(HANDSHAKE_DEADLINE_S, self.close)
        task = loop.create_task(self._open_upstream())
        task.add_done_callback(_quiet)

    async def _open_upstream(self) -> None:
        loop = asyncio.get_running_loop()
        try:
            _, upstream = await loop.create_connection(
                lambda: _Upstream(self), "127.0.0.1", self.gate.upstream_port
            )
        except OSError:
            self.close()
            return
        if self._closed:
            upstream.close()
            return
        self.upstream = upstream
        upstream.send(bytes(self._early))
        self._early.clear()

    def data_received(self, data: bytes) -> None:
        if self._closed:
            return  # a refused viewer's request, read to be dropped
        if not self._requested:  # the opening request goes on whole, its protocol named
            self._head += data
            end = self._head.find(b"\r\n\r\n")
            if end < 0:
                if len(self._head) > MAX_REQUEST_BYTES:
                    self.close()
                return
            self._requested = True
            if self._deadline is not None:
                self._deadline.cancel()
            request, self.legacy = spoken_as_sdk(bytes(self._head[: end + 4]))
            data = request + bytes(self._head[end + 4 :])
            self._head = bytearray()
        if self.upstream is not None:
            self.upstream.send(data)
        elif not self._closed:
            self._early += data
            if len(self._early) > UPSTREAM_HIGH_BYTES:  # the SDK's end never opened
                self.close()

    def send(self, data: bytes) -> None:
        """From the SDK to the viewer."""
        if self.transport is not None and not self._closed:
            self.transport.write(data)

    def pause_writing(self) -> None:
        """Past ``buffer_bytes`` waiting for this viewer: it is too slow, let it go."""
        assert self.transport is not None
        self.gate.drop_slow(self, self.transport.get_write_buffer_size())
        self.close(abort=True)

    def resume_writing(self) -> None:
        """Not used: a viewer past its budget is dropped, not waited for."""

    def connection_lost(self, exc: Exception | None) -> None:
        self.close()

    def close(self, *, abort: bool = False) -> None:
        if self._closed:
            return
        self._closed = True
        self.gate.viewers.discard(self)
        if self._deadline is not None:
            self._deadline.cancel()
        if self.transport is not None:
            if abort:
                self.transport.abort()  # what waits for it is dropped at once
            else:
                self.transport.close()
        if self.upstream is not None:
            self.upstream.close()
        self._early.clear()
        self._head.clear()


class _Upstream(asyncio.Protocol):
    """The gate's connection to the SDK's server for one viewer."""

    def __init__(self, viewer: _Viewer) -> None:
        self.viewer = viewer
        self.transport: asyncio.Transport | None = None
        self._answer = bytearray()  # the SDK's answer to a legacy viewer, until whole
        self._answered = False

    def connection_made(self, transport: Any) -> None:
        self.transport = transport
        transport.set_write_buffer_limits(high=UPSTREAM_HIGH_BYTES)

    def data_received(self, data: bytes) -> None:
        if self.viewer.legacy and not self._answered:
            self._answer += data
            end = self._answer.find(b"\r\n\r\n")
            if end < 0:
                return
            self._answered = True
            head = bytes(self._answer[: end + 4]).replace(SDK_PROTOCOL, LEGACY_PROTOCOL)
            data = head + bytes(self._answer[end + 4 :])
            self._answer = bytearray()
        self.viewer.send(data)

    def send(self, data: bytes) -> None:
        """From the viewer to the SDK."""
        if self.transport is not None and data:
            self.transport.write(data)

    def pause_writing(self) -> None:
        """The SDK reads slower than the viewer writes: stop reading the viewer."""
        if self.viewer.transport is not None:
            self.viewer.transport.pause_reading()

    def resume_writing(self) -> None:
        if self.viewer.transport is not None and not self.viewer.transport.is_closing():
            self.viewer.transport.resume_reading()

    def connection_lost(self, exc: Exception | None) -> None:
        self.viewer.close()

    def close(self) -> None:
        if self.transport is not None:
            self.transport.close()


async def serve_viewers(
    host: str, port: int, limits: Any, log: Any, **server: Any
) -> tuple[WebSocketServer, ViewerGate]:
    """The SDK's server (``server``: ``foxglove.start_server``'s other arguments) on a free
    loopback port, and the gate on ``host``:``port`` in front of it.

    Raises:
        OSError: the gate's address cannot be bound (the SDK's server is stopped again).
        RuntimeError: the SDK's server could not start.
    """
    sdk = foxglove.start_server(
        host="127.0.0.1", port=0, message_backlog_size=SDK_BACKLOG_MESSAGES, **server
    )
    gate = ViewerGate(sdk.port, limits, log)
    try:
        await gate.listen(host, port)
    except BaseException:
        sdk.stop()
        raise
    return sdk, gate


def spoken_as_sdk(request: bytes) -> tuple[bytes, bool]:
    """The opening request as the SDK takes it, and whether it was changed: a viewer that
    asks for ``foxglove.websocket.v1`` only (Lichtblick before December 2025, the
    ``@foxglove/ws-protocol`` client) is asked for as ``foxglove.sdk.v1``, the same protocol
    under the SDK's name (Foxglove says so), and answered under the name it asked for."""
    lines = request.split(b"\r\n")
    for index, line in enumerate(lines):
        name, colon, value = line.partition(b":")
        if not colon or name.strip().lower() != b"sec-websocket-protocol":
            continue
        offered = [token.strip() for token in value.split(b",")]
        if SDK_PROTOCOL in offered or LEGACY_PROTOCOL not in offered:
            return request, False
        lines[index] = name + b": " + SDK_PROTOCOL
        return b"\r\n".join(lines), True
    return request, False


def _quiet(task: asyncio.Task[None]) -> None:
    """A connection task's end: nothing to report (its failures close the viewer)."""
    with contextlib.suppress(asyncio.CancelledError):
        task.exception()
