"""One TCP connection: newline framing with a size limit, a handshake deadline, bounded output.

The connection knows nothing of roles or messages: it cuts the byte stream into lines and
hands the lines of each read, in order, to its ``LineSink`` (the server). A line longer than
the limit is answered with an error and discarded up to its newline; the connection stays
usable. Output is bounded: droppable frames (status) are dropped when the client does not
read fast enough; a client whose droppable frames have all been dropped for
``slow_reader_s``, or that lets even its replies pile up past a hard cap, is disconnected.
"""

from __future__ import annotations

import asyncio
import contextlib
import math
import socket
from typing import Protocol, cast

from navd.wire import ErrorFrame, ReplyPart, encode

__all__ = ["Connection", "LineSink"]

HARD_CAP_FACTOR = 4
# The kernel may hold this much unsent output per connection [bytes] (it doubles it); left to
# its autotuning it grows to megabytes, and a client that stopped reading would keep its slot
# for minutes before navd's own bound on output ever saw a byte pile up.
SEND_BUFFER_BYTES = 64 * 1024
CLOSE_GRACE_S = 2.0  # [s] a closing connection's output has this long to drain


class LineSink(Protocol):
    """What a connection reports to."""

    def on_open(self, conn: Connection) -> bool:
        """A client connected; False refuses it (the sink has sent the reason)."""
        ...

    def on_lines(self, conn: Connection, lines: list[bytes]) -> None:
        """Complete lines that arrived together, in order, without their newlines."""
        ...

    def on_close(self, conn: Connection, reason: str) -> None:
        """The connection ended."""
        ...


class Connection(asyncio.Protocol):
    """asyncio protocol for one client.

    Args:
        sink: receives lines and lifecycle events.
        max_line_bytes: longest accepted line, newline excluded.
        handshake_timeout_s: [s] real time the client has before ``handshake_done``.
        write_high_bytes: output buffered beyond this drops droppable frames.
        slow_reader_s: [s] droppable frames dropped without a break for this long close the
            connection (the client stopped reading).
    """

    def __init__(
        self,
        sink: LineSink,
        *,
        max_line_bytes: int,
        handshake_timeout_s: float,
        write_high_bytes: int,
        slow_reader_s: float,
    ) -> None:
        self.sink = sink
        self.max_line_bytes = max_line_bytes
        self.handshake_timeout_s = handshake_timeout_s
        self.write_high_bytes = write_high_bytes
        self.slow_reader_s = slow_reader_s
        self._dropping_since: float | None = None  # [s] loop time of the first unbroken drop
        self.peer = "?"
        self.dropped_frames = 0
        self.session: object = None  # the server's session, once the handshake is done
        self.coalesce_s = 0.0  # [s] pause after each read (set for sensor sessions)
        self._resume: asyncio.TimerHandle | None = None
        self._last_read_s = -math.inf  # [s] loop time of the last read
        self._buffer = bytearray()
        self._discarding = False
        self._transport: asyncio.Transport | None = None
        self._handshake_timer: asyncio.TimerHandle | None = None
        self._close_reason = "client disconnected"

    # --- asyncio.Protocol -------------------------------------------------------------

    def connection_made(self, transport: asyncio.BaseTransport) -> None:
        # uvloop's transports implement the asyncio.Transport interface without subclassing it
        self._transport = cast(asyncio.Transport, transport)
        sock = transport.get_extra_info("socket")
        if sock is not None:
            with contextlib.suppress(OSError):
                sock.setsockopt(socket.SOL_SOCKET, socket.SO_SNDBUF, SEND_BUFFER_BYTES)
        peer = transport.get_extra_info("peername")
        self.peer = f"{peer[0]}:{peer[1]}" if isinstance(peer, tuple) else str(peer)
        if not self.sink.on_open(self):
            self.close("refused")
            return
        self._handshake_timer = asyncio.get_running_loop().call_later(
            self.handshake_timeout_s, self._handshake_expired
        )

    def data_received(self, data: bytes) -> None:
        buffer = self._buffer
        buffer += data
        start = 0
        lines: list[bytes] = []
        while True:
            end = buffer.find(b"\n", start)
            if end < 0:
                break
            if self._discarding:
                self._discarding = False
            elif end - start > self.max_line_bytes:
                self._deliver(lines)  # keep answers in the order of the lines
                lines = []
                self._too_long()
            else:
                lines.append(bytes(buffer[start:end]))
            start = end + 1
        del buffer[:start]
        self._deliver(lines)
        if len(buffer) > self.max_line_bytes:
            if not self._discarding:
                self._too_long()
            self._discarding = True
            buffer.clear()
        if self.coalesce_s > 0.0 and self._resume is None and self.open:
            # A stream faster than one line per coalescing window (several lines in this
            # read, or a read soon after the last): let its lines gather in the kernel, so
            # the next read takes all of them in one wakeup. A slower stream (a lidar, a
            # GPS) is read the moment each line comes and pays no timer: every wakeup
            # costs, on a small board more than the handling of a line.
            loop = asyncio.get_running_loop()
            now = loop.time()
            if len(lines) > 1 or now - self._last_read_s < self.coalesce_s:
                assert self._transport is not None
                self._transport.pause_reading()
                self._resume = loop.call_later(self.coalesce_s, self._read_again)
            self._last_read_s = now

    def _deliver(self, lines: list[bytes]) -> None:
        if lines and self.open:
            self.sink.on_lines(self, lines)

    def _read_again(self) -> None:
        self._resume = None
        if self.open:
            assert self._transport is not None
            self._transport.resume_reading()

    def connection_lost(self, exc: Exception | None) -> None:
        if self._handshake_timer is not None:
            self._handshake_timer.cancel()
        if self._resume is not None:
            self._resume.cancel()
        reason = self._close_reason if exc is None else f"connection error: {exc}"
        self._transport = None
        self.sink.on_close(self, reason)

    # --- used by the server -----------------------------------------------------------

    @property
    def open(self) -> bool:
        """True until the connection starts closing."""
        return self._transport is not None and not self._transport.is_closing()

    def handshake_done(self) -> None:
        """Cancel the handshake deadline."""
        if self._handshake_timer is not None:
            self._handshake_timer.cancel()
            self._handshake_timer = None

    def send(self, frame: ReplyPart, *, droppable: bool = False) -> bool:
        """Queue one frame; returns False if it was dropped (slow reader) or the link is down."""
        return self.send_line(encode(frame), droppable=droppable)

    def send_line(self, line: bytes, *, droppable: bool = False) -> bool:
        """Queue one encoded frame (a frame sent to many clients is encoded once)."""
        transport = self._transport
        if transport is None or transport.is_closing():
            return False
        buffered = transport.get_write_buffer_size()
        if droppable and buffered > self.write_high_bytes:
            self.dropped_frames += 1
            now = asyncio.get_running_loop().time()
            if self._dropping_since is None:
                self._dropping_since = now
            elif now - self._dropping_since > self.slow_reader_s:
                self.close(
                    f"client does not read: status frames dropped for {self.slow_reader_s:g} s"
                )
            return False
        if droppable:
            self._dropping_since = None
        if buffered > self.write_high_bytes * HARD_CAP_FACTOR:
            self.close("client does not read its replies; output buffer full")
            return False
        transport.write(line)
        return True

    def close(self, reason: str, error: ErrorFrame | None = None) -> None:
        """Close, optionally sending a last (fatal) error frame first. What is still
        buffered goes out first, for at most ``CLOSE_GRACE_S``: a client that does not read
        is then cut off, so its slot is free either way."""
        transport = self._transport
        if transport is None or transport.is_closing():
            return
        self._close_reason = reason
        if error is not None:
            transport.write(encode(error))
        transport.close()
        asyncio.get_running_loop().call_later(CLOSE_GRACE_S, self._abort, transport)

    def _abort(self, transport: asyncio.Transport) -> None:
        if self._transport is transport:  # still not gone: its output never drained
            transport.abort()

    def _too_long(self) -> None:
        self.send(
            ErrorFrame(
                field="",
                reason=f"line longer than the limit of {self.max_line_bytes} bytes "
                f"(tcp.max_line_bytes); it was discarded",
            )
        )

    def _handshake_expired(self) -> None:
        self._handshake_timer = None
        if self.session is None:
            self.close(
                "no hello in time",
                ErrorFrame(
                    field="type",
                    reason=f"no hello within {self.handshake_timeout_s:g} s "
                    f"(tcp.handshake_timeout_s)",
                    fatal=True,
                ),
            )
