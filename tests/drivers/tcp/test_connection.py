"""Line framing and bounded output of one connection, with a fake transport."""

from __future__ import annotations

import asyncio
import json
from typing import Any

import pytest

from navd.drivers.tcp.connection import Connection
from navd.wire import ErrorFrame, Pong


class FakeTransport(asyncio.Transport):
    def __init__(self) -> None:
        super().__init__()
        self.written = bytearray()
        self.buffered = 0
        self.closed = False
        self.reading = True

    def pause_reading(self) -> None:
        self.reading = False

    def resume_reading(self) -> None:
        self.reading = True

    def get_extra_info(self, name: str, default: Any = None) -> Any:
        return ("127.0.0.1", 5555) if name == "peername" else default

    def write(self, data: bytes | bytearray | memoryview) -> None:
        self.written += data

    def get_write_buffer_size(self) -> int:
        return self.buffered

    def is_closing(self) -> bool:
        return self.closed

    def close(self) -> None:
        self.closed = True

    def abort(self) -> None:
        self.closed = True


class Sink:
    def __init__(self) -> None:
        self.lines: list[bytes] = []
        self.batches: list[int] = []
        self.closed: list[str] = []

    def on_open(self, conn: Connection) -> bool:
        return True

    def on_lines(self, conn: Connection, lines: list[bytes]) -> None:
        self.lines.extend(lines)
        self.batches.append(len(lines))

    def on_close(self, conn: Connection, reason: str) -> None:
        self.closed.append(reason)


@pytest.fixture
async def wired() -> tuple[Connection, FakeTransport, Sink]:
    sink = Sink()
    conn = Connection(
        sink,
        max_line_bytes=16,
        handshake_timeout_s=60.0,
        write_high_bytes=100,
        slow_reader_s=0.2,
    )
    transport = FakeTransport()
    conn.connection_made(transport)
    conn.handshake_done()
    return conn, transport, sink


async def test_lines_are_reassembled_across_chunks(wired: Any) -> None:
    conn, _, sink = wired
    for chunk in (b"ab", b"c\nde", b"f\n\ng", b"h\n"):
        conn.data_received(chunk)
    assert sink.lines == [b"abc", b"def", b"", b"gh"]
    assert sink.batches == [1, 2, 1]  # the lines of one read are handed over together


async def test_a_fast_stream_is_read_in_batches_a_slow_one_line_by_line(wired: Any) -> None:
    conn, transport, sink = wired
    conn.coalesce_s = 0.03
    conn.data_received(b"a\n")  # a first line: read at once, nothing to batch yet
    assert transport.reading
    conn.data_received(b"b\n")  # the next one soon after: a fast stream, let lines gather
    assert not transport.reading
    await asyncio.sleep(0.05)
    assert transport.reading  # the window is over: the next read takes what gathered
    await asyncio.sleep(0.05)
    conn.data_received(b"c\n")  # a line per 100 ms: read as it comes, no pause, no timer
    assert transport.reading
    conn.data_received(b"d\ne\n")  # several lines in one read: a fast stream again
    assert not transport.reading
    assert sink.lines == [b"a", b"b", b"c", b"d", b"e"]


async def test_overlong_line_is_discarded_up_to_its_newline(wired: Any) -> None:
    conn, transport, sink = wired
    conn.data_received(b"0123456789")
    conn.data_received(b"0123456789")  # 20 bytes pending without a newline: over the limit
    conn.data_received(b"still the same line\nok\n")
    assert sink.lines == [b"ok"]
    errors = [json.loads(x) for x in bytes(transport.written).splitlines()]
    assert len(errors) == 1 and "longer than the limit of 16 bytes" in errors[0]["reason"]


async def test_overlong_complete_line_in_one_chunk_keeps_the_order(wired: Any) -> None:
    conn, transport, sink = wired
    order: list[str] = []
    sink.on_lines = lambda c, lines: order.extend(x.decode() for x in lines)  # type: ignore[method-assign]
    transport.write = lambda data: order.append("error")  # type: ignore[method-assign]
    conn.data_received(b"before\n" + b"x" * 40 + b"\nafter\n")
    assert order == ["before", "error", "after"]


async def test_slow_reader_loses_droppable_frames_only(wired: Any) -> None:
    conn, transport, _ = wired
    transport.buffered = 150  # above the high-water mark of 100 bytes
    assert not conn.send(Pong(id=1), droppable=True)
    assert conn.dropped_frames == 1
    assert conn.send(ErrorFrame(field="", reason="x"))  # replies go out below the hard cap
    transport.buffered = 401  # beyond 4x the high-water mark: the client is not reading
    assert not conn.send(ErrorFrame(field="", reason="x"))
    assert transport.closed


async def test_a_client_whose_status_frames_all_drop_for_long_is_disconnected(
    wired: Any,
) -> None:
    conn, transport, _ = wired
    transport.buffered = 150  # the client reads nothing: every status frame is dropped
    assert not conn.send(Pong(id=1), droppable=True)
    await asyncio.sleep(0.1)
    assert not conn.send(Pong(id=2), droppable=True)
    assert not transport.closed  # 0.1 s of drops is a slow moment, not a dead reader
    transport.buffered = 50  # it read: a frame goes out and the drop spell ends
    assert conn.send(Pong(id=3), droppable=True)
    transport.buffered = 150
    assert not conn.send(Pong(id=4), droppable=True)
    await asyncio.sleep(0.15)
    assert not conn.send(Pong(id=5), droppable=True)
    assert not transport.closed  # 0.15 s since the spell began anew
    await asyncio.sleep(0.1)
    assert not conn.send(Pong(id=6), droppable=True)
    assert transport.closed
