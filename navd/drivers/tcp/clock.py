"""The clock role: one simulator drives a daemon on simulated time, step by step.

Each clock frame is queued and run in order by the session's task: wait for the lines the
simulator says it sent, move the clock (``Lockstep``), and answer with a ``clock_ack``.
"""

from __future__ import annotations

import asyncio
from collections.abc import Callable, Iterable

from navd.drivers.tcp.session import Server, Session
from navd.lifecycle import LifecycleError, Lockstep, SimClock
from navd.lifecycle.messages import DeviceKind
from navd.wire import ClockAck, ErrorFrame, PingFrame, Pong, WireError, decode_clock

__all__ = ["CLOCK_QUEUE", "ClockRole"]

CLOCK_QUEUE = 16  # clock frames waiting: a simulator sends one and waits for its answer


class ClockRole:
    """Handles the clock session (there is at most one).

    Args:
        server: the server.
        lockstep_timeout_s: the real time a step waits for lines, read at each step.
    """

    def __init__(self, server: Server, lockstep_timeout_s: Callable[[], float]) -> None:
        self._server = server
        self._timeout_s = lockstep_timeout_s
        clock = server.ctx.clock
        self.lockstep = (
            Lockstep(clock, server.ctx.workers, server.ctx.line_counts)
            if isinstance(clock, SimClock)
            else None
        )

    def refusal(self, device_id: str, sessions: Iterable[Session]) -> str:
        """Why a clock client ``device_id`` may not connect now ("" if it may)."""
        if self.lockstep is None:
            return (
                "this daemon runs on real time (lifecycle.clock = 'real'); start it with "
                "lifecycle.clock = 'simulated' to let a simulator drive its clock"
            )
        for session in sessions:
            if session.kind is DeviceKind.CLOCK and session.device_id != device_id:
                return (
                    f"clock client {session.device_id!r} already drives the time; one "
                    "simulator owns the clock"
                )
        return ""

    def opened(self, session: Session) -> None:
        session.clock_frames = asyncio.Queue(CLOCK_QUEUE)
        session.clock_task = self._server.ctx.spawn(
            self._run(session), name=f"clock:{session.device_id}"
        )

    def lines(self, session: Session, lines: list[bytes]) -> None:
        self._server.each_line(session, lines, lambda line: self._frame(session, line))

    def closed(self, session: Session) -> None:
        if session.clock_task is not None:
            session.clock_task.cancel()

    def _frame(self, session: Session, line: bytes) -> None:
        frame = decode_clock(line)
        if isinstance(frame, PingFrame):
            session.conn.send(Pong(id=frame.id))
            return
        assert session.clock_frames is not None
        try:
            session.clock_frames.put_nowait(frame)
        except asyncio.QueueFull:
            raise WireError(
                "", f"{CLOCK_QUEUE} clock frames already waiting; wait for each clock_ack"
            ) from None
        session.accepted += 1

    async def _run(self, session: Session) -> None:
        """Step the clock for each clock frame, in order, and answer each."""
        assert self.lockstep is not None and session.clock_frames is not None
        ctx = self._server.ctx
        while session.conn.open:
            frame = await session.clock_frames.get()
            session.last_rx_s = ctx.clock.now()
            timeout_s = self._timeout_s()
            try:
                report = await self.lockstep.step_to(frame.time, frame.frames, timeout_s)
            except LifecycleError as err:
                session.rejected += 1
                session.conn.send(ErrorFrame(field="time", reason=str(err)))
                continue
            if report.missing:
                ctx.log.warning(
                    "lockstep_lines_missing",
                    time_s=report.time_s,
                    missing=report.missing,
                    waited_s=timeout_s,
                )
            session.conn.send(
                ClockAck(time=report.time_s, sent=report.sent, missing=report.missing or None)
            )
