"""The TCP peripheral server: sensor, control and clock clients that come and go while navd
runs.

Every connection starts with a ``hello`` naming its role and device id; the server checks it
(token, protocol, a clock client only on simulated time), replaces an older session with the
same id, and hands the session's lines to its role's handler (``sensors``, ``control``,
``clock``). Hot-plug is published as DeviceConnected / DeviceLost, and a device silent for
longer than its kind's timeout as DeviceStale (DeviceResumed when it speaks again). Every
rejected line is answered with an error naming the field; the connection and the other
clients carry on.
"""

from __future__ import annotations

import asyncio
import re
from collections.abc import Callable

from navd import __version__
from navd.drivers.errors import DriverError
from navd.drivers.tcp.admission import admission_refusal
from navd.drivers.tcp.clock import ClockRole
from navd.drivers.tcp.connection import Connection
from navd.drivers.tcp.control import ControlRole
from navd.drivers.tcp.sensors import SensorRole
from navd.drivers.tcp.session import Role, Session
from navd.drivers.tcp.settings import (
    ConnectionLimits,
    SensorPacing,
    TcpSettings,
)
from navd.drivers.tcp.status_board import StatusBoard
from navd.drivers.tcp.watch import SilenceWatch
from navd.lifecycle import MessageError, Module, ModuleContext
from navd.lifecycle.messages import (
    DeviceConnected,
    DeviceKind,
    DeviceLost,
    DeviceResumed,
)
from navd.wire import (
    PROTOCOL_VERSION,
    SENSOR_FRAMES,
    DeviceInfo,
    ErrorFrame,
    StatusFrame,
    Welcome,
    WireError,
    decode_hello,
)

__all__ = ["TcpServer"]

TOKEN_VALUE = re.compile(rb'"token"\s*:\s*"[^"]*"?')


class TcpServer(Module):
    """The TCP server module ("tcp")."""

    def __init__(self) -> None:
        super().__init__("tcp")
        self.sessions: dict[str, Session] = {}
        self.connections: set[Connection] = set()
        self._server: asyncio.Server | None = None
        self.board = StatusBoard()
        self._pending: dict[Connection, None] = {}  # no hello yet, oldest first
        self._evicted = 0

    # --- lifecycle --------------------------------------------------------------------

    async def on_configure(self, ctx: ModuleContext) -> None:
        self.ctx = ctx
        self.settings = ctx.settings(TcpSettings.from_config, self._settings_changed)
        self.watch = SilenceWatch(ctx, self.sessions.values, lambda: self.settings.value)
        self.board.subscribe(ctx)
        # a new or resumed device may fall silent before the watch's next deadline
        ctx.subscribe(DeviceConnected, self.wake_watch)
        ctx.subscribe(DeviceResumed, self.wake_watch)
        self.clock_role = ClockRole(self, lambda: self.settings.value.lockstep_timeout_s)
        control = ControlRole(
            self,
            self.sessions.values,
            self.status_frame,
            lambda: self.settings.value.allow_privileged_changes,
            lambda: self.settings.value.teleop_enabled,
        )
        sensors = SensorRole(self)
        self._roles: dict[DeviceKind, Role] = {DeviceKind(r): sensors for r in SENSOR_FRAMES}
        self._roles[DeviceKind.CONTROL] = control
        self._roles[DeviceKind.CLOCK] = self.clock_role

    async def on_activate(self) -> None:
        tcp = self.settings.value
        loop = asyncio.get_running_loop()
        try:
            self._server = await loop.create_server(
                self._new_connection, host=tcp.host, port=tcp.port, reuse_address=True
            )
        except OSError as err:
            raise DriverError(
                f"tcp: cannot listen on {tcp.host}:{tcp.port}: {err.strerror or err}; is another "
                f"navd running? (change tcp.port or tcp.host)"
            ) from err
        address = self._server.sockets[0].getsockname()
        self.ctx.log.info(
            "listening", host=address[0], port=address[1], token_required=tcp.token is not None
        )
        self.ctx.spawn(self.watch.run(), name="silence")

    async def on_deactivate(self) -> None:
        if self._server is not None:
            self._server.close()
        for conn in list(self.connections):
            conn.close(
                "daemon stopping", ErrorFrame(field="", reason="daemon stopping", fatal=True)
            )
        if self._server is not None:
            await self._server.wait_closed()
            self._server = None

    def settings_in_use(self) -> tuple[object, ...]:
        """The server's settings, and what every open connection holds of them."""
        held: list[object] = [self.settings.value]
        for conn in self.connections:
            held.append(
                ConnectionLimits(conn.max_line_bytes, conn.write_high_bytes, conn.slow_reader_s)
            )
            if isinstance(conn.session, Session) and conn.session.kind.value in SENSOR_FRAMES:
                held.append(SensorPacing(conn.coalesce_s))
        return tuple(held)

    def _settings_changed(self, _old: TcpSettings, new: TcpSettings) -> None:
        """Connections open now take the new limits too (a new handshake deadline applies
        only to connections made after it)."""
        self.wake_watch()
        limits = new.connection
        for conn in self.connections:
            conn.max_line_bytes = limits.max_line_bytes
            conn.write_high_bytes = limits.write_high_bytes
            conn.slow_reader_s = limits.slow_reader_s
            session = conn.session
            if isinstance(session, Session) and session.kind.value in SENSOR_FRAMES:
                conn.coalesce_s = new.pacing.coalesce_s

    @property
    def port(self) -> int:
        """The bound port (useful when the config asked for port 0 in tests)."""
        assert self._server is not None, "server not active"
        port: int = self._server.sockets[0].getsockname()[1]
        return port

    # --- connections (the LineSink of every Connection) ---------------------------------

    def _new_connection(self) -> Connection:
        tcp = self.settings.value
        return Connection(
            self,
            max_line_bytes=tcp.connection.max_line_bytes,
            handshake_timeout_s=tcp.handshake_timeout_s,
            write_high_bytes=tcp.connection.write_high_bytes,
            slow_reader_s=tcp.connection.slow_reader_s,
        )

    def on_open(self, conn: Connection) -> bool:
        """Take every connection; past ``tcp.max_pending`` waiting for their hello, the
        oldest waiting one goes (a flood of silent connections never keeps a client out)."""
        self.connections.add(conn)
        self._pending[conn] = None
        limit = self.settings.value.max_pending
        while len(self._pending) > limit:
            oldest = next(iter(self._pending))
            del self._pending[oldest]
            reason = (
                f"closed unauthenticated: {limit} newer connections are waiting to say hello "
                "(tcp.max_pending); say hello at once"
            )
            oldest.close("evicted", ErrorFrame(field="", reason=reason, fatal=True))
            self._evicted += 1
            if self._evicted == 1 or self._evicted % 100 == 0:
                self.ctx.log.warning(
                    "client_evicted", peer=oldest.peer, evicted=self._evicted, limit=limit
                )
        return True

    def on_lines(self, conn: Connection, lines: list[bytes]) -> None:
        session = conn.session
        if not isinstance(session, Session):
            # the first non-blank line is the hello; what follows it belongs to the role
            for index, line in enumerate(lines):
                if line and not line.isspace():
                    try:
                        session = self._handshake(conn, line)
                    except Exception as err:  # a bug, not a bad hello: refuse, count, go on
                        self.reject(conn, line, err)
                        conn.close("handshake failed")
                        return
                    lines = lines[index + 1 :]
                    break
            else:
                return
            if session is None or not lines:
                return
        self._roles[session.kind].lines(session, lines)

    def each_line(
        self, session: Session, lines: list[bytes], handle: Callable[[bytes], None]
    ) -> None:
        """Hand each non-blank line to ``handle``; a line that raises is answered by
        ``reject`` and the lines after it go on."""
        for line in lines:
            if not session.conn.open:
                return
            if not line or line.isspace():
                continue  # blank lines are allowed (keep-alives, a person pressing enter)
            try:
                handle(line)
            except Exception as err:  # the supervised boundary per line: see reject
                self.reject(session.conn, line, err)

    def reject(self, conn: Connection, line: bytes, err: Exception) -> None:
        """Answer a line that could not be used; the one supervised boundary per line."""
        session = conn.session
        if isinstance(session, Session):
            session.rejected += 1
        if isinstance(err, WireError):
            conn.send(ErrorFrame(field=err.field, reason=err.reason))
        elif isinstance(err, MessageError):
            conn.send(ErrorFrame(field="", reason=str(err)))
        else:  # a bug, not bad input: counted against this module, the client is told
            shown = TOKEN_VALUE.sub(rb'"token": "<redacted>"', line[:200])  # a hello's secret
            self.ctx.bus.report_failure(self.name, {"peer": conn.peer, "line": shown}, err)
            conn.send(ErrorFrame(field="", reason="internal error on this frame"))

    def on_close(self, conn: Connection, reason: str) -> None:
        self.connections.discard(conn)
        self._pending.pop(conn, None)
        session = conn.session
        if not isinstance(session, Session):
            return
        self._roles[session.kind].closed(session)
        if session.replaced or self.sessions.get(session.device_id) is not session:
            return
        del self.sessions[session.device_id]
        if session.kind is DeviceKind.CLOCK:
            self.ctx.log.warning(
                "clock_client_lost",
                device_id=session.device_id,
                time_s=self.ctx.clock.now(),
                effect="simulated time stands still until a clock client connects",
            )
        self._lost(session, reason)

    # --- handshake ----------------------------------------------------------------------

    def _handshake(self, conn: Connection, line: bytes) -> Session | None:
        """The session a hello opens, or None (the connection was refused and is closing)."""
        try:
            hello = decode_hello(line)
        except WireError as err:
            conn.close("bad hello", ErrorFrame(field=err.field, reason=err.reason, fatal=True))
            return None
        refusal = admission_refusal(hello, self.sessions, self.settings.value, self.clock_role)
        if refusal is not None:
            field, reason = refusal
            conn.close(reason, ErrorFrame(field=field, reason=reason, fatal=True))
            self.ctx.log.warning("client_refused", peer=conn.peer, reason=reason)
            return None
        now = self.ctx.clock.now()
        kind = DeviceKind(hello.role)
        old = self.sessions.get(hello.device_id)
        if old is not None:
            # A sensor's id stays with its first connection until that one leaves or falls
            # silent (a second hello cannot cut off a working sensor); a control client's
            # goes to the newest (a user interface reconnecting over a link that died).
            why = (
                "replaced by a new connection after going silent"
                if old.kind is not DeviceKind.CONTROL
                else "replaced by a new connection with this id"
            )
            old.replaced = True
            old.conn.close("replaced", ErrorFrame(field="device_id", reason=why, fatal=True))
            self._lost(old, why)
        session = Session(hello.device_id, kind, conn, connected_s=now, last_rx_s=now)
        self._pending.pop(conn, None)
        self.sessions[hello.device_id] = session
        conn.session = session
        conn.handshake_done()
        if hello.role in SENSOR_FRAMES:
            conn.coalesce_s = self.settings.value.pacing.coalesce_s
        self._roles[kind].opened(session)
        conn.send(
            Welcome(
                protocol=PROTOCOL_VERSION,
                daemon=f"navd {__version__}",
                device_id=hello.device_id,
                role=hello.role,
                max_line_bytes=self.settings.value.connection.max_line_bytes,
            )
        )
        self.ctx.log.info(
            "device_connected",
            device_id=hello.device_id,
            kind=hello.role,
            peer=conn.peer,
            replaced=old is not None,
        )
        self.ctx.publish(
            DeviceConnected(stamp=now, received=now, device_id=hello.device_id, kind=kind)
        )
        return session

    def _lost(self, session: Session, reason: str) -> None:
        now = self.ctx.clock.now()
        self.ctx.log.info(
            "device_lost", device_id=session.device_id, kind=session.kind.value, reason=reason
        )
        self.ctx.publish(
            DeviceLost(
                stamp=now,
                received=now,
                device_id=session.device_id,
                kind=session.kind,
                reason=reason,
                spoke=bool(session.arrivals),
            )
        )

    # --- status ---------------------------------------------------------------------------

    def status_frame(self) -> StatusFrame:
        """The status a subscribed control client receives."""
        now = self.ctx.clock.now()
        devices = [
            DeviceInfo(
                device_id=s.device_id,
                kind=s.kind.value,
                connected_s=round(now - s.connected_s, 3),
                silent_s=round(now - s.last_rx_s, 3),
                stale=s.stale,
                accepted=s.accepted,
                rejected=s.rejected,
            )
            for s in self.sessions.values()
        ]
        return self.board.frame(now, self.settings.value.robot_name, devices)

    def wake_watch(self, _msg: object = None) -> None:
        """A new or resumed device, or new timeouts: the silence watch sets its next deadline
        anew."""
        self.watch.wake()
