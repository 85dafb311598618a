"""The silence watch: a sensor that sends no data past its timeout is stale; a sensor that
sends nothing at all for ``tcp.sensor_idle_timeout_s``, or a control client without a
status subscription for ``tcp.control_idle_timeout_s``, is disconnected (it frees its slot).

It sleeps until the earliest deadline of all sessions, not on a fixed poll (which would add
its period to every detection): a lidar falls stale the moment its silence passes its
timeout. A new or resumed device, or new timeouts, wake it to set its next deadline anew.
"""

from __future__ import annotations

import asyncio
import math
from collections.abc import Callable, Iterable

from navd.drivers.tcp.session import Session
from navd.drivers.tcp.settings import TcpSettings
from navd.lifecycle import ModuleContext
from navd.lifecycle.messages import DeviceKind, DeviceStale
from navd.wire import ErrorFrame

__all__ = ["SilenceWatch", "stale_after_s"]

# A sensor slower than its kind's timeout is stale after its own period x factor + margin.
OWN_PERIOD_FACTOR = 1.25
OWN_PERIOD_MARGIN_S = 0.05
MAX_SLEEP_S = 1.0  # [s] the watch looks again at least this often (a clock that jumps)


def stale_after_s(session: Session, settings: TcpSettings) -> float | None:
    """[s] the silence that makes this session's device stale: its kind's configured
    timeout, or for a sensor slower than that, its own period x 1.25 + 50 ms (a 5 Hz lidar is
    not stale between two of its scans). None: the kind never goes stale."""
    timeout = dict(settings.stale_after_s).get(session.kind)
    if timeout is None:
        return None
    gap = session.typical_gap_s()
    if gap is None:
        return timeout
    return max(timeout, OWN_PERIOD_FACTOR * gap + OWN_PERIOD_MARGIN_S)


class SilenceWatch:
    """Watches every session's silence.

    Args:
        ctx: the server's context (clock, log, bus).
        sessions: the sessions connected now.
        settings: the server's settings in force.
    """

    def __init__(
        self,
        ctx: ModuleContext,
        sessions: Callable[[], Iterable[Session]],
        settings: Callable[[], TcpSettings],
    ) -> None:
        self.ctx = ctx
        self._sessions = sessions
        self._settings = settings
        self._wakeup = asyncio.Event()

    def wake(self) -> None:
        """Look at every session's deadline again (one is new, or the timeouts changed)."""
        self._wakeup.set()

    async def run(self) -> None:
        """Mark stale and close idle sessions as their deadlines pass, for ever."""
        while True:
            now = self.ctx.clock.now()
            next_deadline = math.inf
            for session in list(self._sessions()):
                idle, stale = self._idle_deadline(session), self._stale_deadline(session)
                if now >= idle:
                    self._close_idle(session, now)
                    continue
                if now >= stale:
                    self._mark_stale(session, now)
                    stale = math.inf
                next_deadline = min(next_deadline, idle, stale)
            self._wakeup.clear()
            sleep = asyncio.ensure_future(
                self.ctx.clock.sleep(min(next_deadline - now, MAX_SLEEP_S))
            )
            wakeup = asyncio.ensure_future(self._wakeup.wait())
            try:
                await asyncio.wait((sleep, wakeup), return_when=asyncio.FIRST_COMPLETED)
            finally:
                sleep.cancel()
                wakeup.cancel()

    def _idle_deadline(self, session: Session) -> float:
        """[s] when the session has sent nothing for too long and is closed: a control
        client without a status subscription, or a sensor; a clock client never is."""
        settings = self._settings()
        if session.kind is DeviceKind.CONTROL:
            if session.status_task is not None and not session.status_task.done():
                return math.inf
            return session.last_line_s + settings.control_idle_timeout_s
        if session.kind is DeviceKind.CLOCK:
            return math.inf
        return session.last_line_s + settings.sensor_idle_timeout_s

    def _stale_deadline(self, session: Session) -> float:
        """[s] when a sensor's silence (no data) makes it stale; inf if it is already."""
        timeout = stale_after_s(session, self._settings())
        if timeout is None or session.stale:
            return math.inf
        return session.last_rx_s + timeout

    def _close_idle(self, session: Session, now: float) -> None:
        idle_s = now - session.last_line_s
        if session.kind is DeviceKind.CONTROL:
            reason = (
                f"idle for {idle_s:.0f} s with no request and no status subscription "
                "(tcp.control_idle_timeout_s); send a ping now and then to stay connected"
            )
        else:
            reason = (
                f"sent nothing for {idle_s:.0f} s (tcp.sensor_idle_timeout_s); connect again "
                "when there is data to send"
            )
        self.ctx.log.info(
            "client_idle",
            device_id=session.device_id,
            kind=session.kind.value,
            idle_s=round(idle_s, 1),
        )
        session.conn.close("idle", ErrorFrame(field="", reason=reason, fatal=True))

    def _mark_stale(self, session: Session, now: float) -> None:
        session.stale = True
        silent = now - session.last_rx_s
        self.ctx.log.warning(
            "device_stale",
            device_id=session.device_id,
            kind=session.kind.value,
            silent_s=round(silent, 3),
        )
        self.ctx.publish(
            DeviceStale(
                stamp=now,
                received=now,
                device_id=session.device_id,
                kind=session.kind,
                silent_s=silent,
                spoke=bool(session.arrivals),
            )
        )
