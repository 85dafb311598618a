"""A client after its handshake, and what its role handler may ask of the server."""

from __future__ import annotations

import asyncio
import itertools
import math
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Protocol

from navd.drivers.tcp.connection import Connection
from navd.drivers.tcp.settings import TcpSettings
from navd.drivers.timesync import StampMapper
from navd.lifecycle import Live, ModuleContext
from navd.lifecycle.messages import DeviceKind
from navd.wire import ClockFrame

__all__ = ["ARRIVALS_KEPT", "Role", "Server", "Session"]

ARRIVALS_KEPT = 17  # reads whose spacing gives a sensor's own period (16 gaps)


@dataclass
class Session:
    """A client that completed its handshake.

    Attributes:
        device_id, kind: who it is.
        conn: its connection.
        connected_s: [s] daemon time it connected.
        last_rx_s: [s] daemon time it last sent what its role is for: data (a sensor), a
            request (a control client). Pings, blank lines and rejected frames do not count.
        last_line_s: [s] daemon time it last sent any line.
        arrivals: [s] daemon times of its recent reads of data (a sensor's own period).
        stamps: its clock mapped onto the daemon's (sensors).
        accepted, rejected: lines used and refused.
        stale: silent past its kind's timeout (sensors).
        replaced: a newer connection took its device id.
        requests: control requests made (numbers the ids it did not give).
        status_task: its status stream (control).
        clock_frames, clock_task: its queued clock steps and their runner (clock).
    """

    device_id: str
    kind: DeviceKind
    conn: Connection
    connected_s: float
    last_rx_s: float
    last_line_s: float = -math.inf
    stamps: StampMapper = field(default_factory=StampMapper)
    accepted: int = 0
    rejected: int = 0
    stale: bool = False
    replaced: bool = False
    requests: int = 0
    status_task: asyncio.Task[None] | None = None
    clock_frames: asyncio.Queue[ClockFrame] | None = None
    clock_task: asyncio.Task[None] | None = None
    arrivals: deque[float] = field(default_factory=lambda: deque(maxlen=ARRIVALS_KEPT))

    def __post_init__(self) -> None:
        self.last_line_s = max(self.last_line_s, self.connected_s)

    def heard(self, now: float) -> None:
        """What its role is for arrived at ``now`` [s] (one read: its lines share an arrival
        time)."""
        self.last_rx_s = now
        self.last_line_s = now
        self.arrivals.append(now)

    def typical_gap_s(self) -> float | None:
        """[s] the median time between the recent reads, or None before there are three."""
        if len(self.arrivals) < 3:
            return None
        gaps = sorted(b - a for a, b in itertools.pairwise(self.arrivals))
        return gaps[len(gaps) // 2]


class Server(Protocol):
    """What a role handler uses of the server."""

    ctx: ModuleContext
    settings: Live[TcpSettings]

    def reject(self, conn: Connection, line: bytes, err: Exception) -> None:
        """Answer a line that could not be used (the supervised boundary per line)."""
        ...

    def each_line(
        self, session: Session, lines: list[bytes], handle: Callable[[bytes], None]
    ) -> None:
        """Hand each non-blank line to ``handle``; one that raises is answered, the rest go
        on."""
        ...

    def wake_watch(self, _msg: object = None) -> None:
        """Have the silence watch look at every session's deadline again."""
        ...


class Role(Protocol):
    """The handler of one role's sessions."""

    def opened(self, session: Session) -> None:
        """The session's handshake was accepted."""
        ...

    def lines(self, session: Session, lines: list[bytes]) -> None:
        """Lines the session sent, in order (blank ones included)."""
        ...

    def closed(self, session: Session) -> None:
        """The session's connection ended."""
        ...
