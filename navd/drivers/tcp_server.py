"""The TCP peripheral server: sensor and control clients that come and go while navd runs.

Every connection starts with a ``hello`` naming its role and device id. Sensor frames become
typed messages on the bus, stamped on the daemon clock; control frames become goals,
cancels, config changes, initial poses and map saves, each acknowledged; a control client
may subscribe to a status stream. Hot-plug is published as DeviceConnected / DeviceLost, and
a device silent for longer than its configured timeout as DeviceStale (DeviceResumed when
it speaks again). The same device id connecting again replaces the old session. Every
rejected line is answered with an ``error`` frame naming the field; the connection and the
other clients carry on.
"""

from __future__ import annotations

import asyncio
import functools
import hmac
from dataclasses import dataclass, field
from typing import Any

from navd import __version__
from navd.drivers.errors import DriverError, WireError
from navd.drivers.status_board import StatusBoard, goal_dict
from navd.drivers.tcp_connection import Connection
from navd.drivers.timesync import StampMapper
from navd.drivers.wire import (
    PROTOCOL_VERSION,
    SENSOR_ROLES,
    ClockFrame,
    PingFrame,
    SubscribeFrame,
    UnsubscribeFrame,
    control_message,
    decode_clock,
    decode_control,
    decode_hello,
    decode_sensor,
    sensor_message,
)
from navd.lifecycle.clock import SimClock
from navd.lifecycle.errors import LifecycleError, MessageError
from navd.lifecycle.lockstep import Lockstep
from navd.lifecycle.messages import (
    ConfigApplied,
    ConfigChange,
    ConfigRejected,
    DeviceConnected,
    DeviceKind,
    DeviceLost,
    DeviceResumed,
    DeviceStale,
    GoalStatus,
    Path,
)
from navd.lifecycle.module import Module, ModuleContext

__all__ = ["TcpServer"]

STALE_CHECK_PERIOD_S = 0.1  # adds at most this to a timeout; each wakeup costs CPU
STATUS_FRAME_BYTES = 4096
CLOCK_QUEUE = 16  # clock frames waiting: a simulator sends one and waits for its answer


@dataclass
class Session:
    """A client that completed its handshake."""

    device_id: str
    kind: DeviceKind
    conn: Connection
    connected_s: float
    last_rx_s: float
    stamps: StampMapper = field(default_factory=StampMapper)
    accepted: int = 0
    rejected: int = 0
    stale: bool = False
    replaced: bool = False
    requests: int = 0
    status_task: asyncio.Task[None] | None = None
    clock_frames: asyncio.Queue[ClockFrame] | None = None
    clock_task: asyncio.Task[None] | None = None


class TcpServer(Module):
    """The TCP server module ("tcp")."""

    def __init__(self) -> None:
        super().__init__("tcp")
        self.sessions: dict[str, Session] = {}
        self.connections: set[Connection] = set()
        self._server: asyncio.Server | None = None
        self._config_requests: dict[str, Session] = {}
        self.board = StatusBoard()
        self.lockstep: Lockstep | None = None

    # --- lifecycle --------------------------------------------------------------------

    async def on_configure(self, ctx: ModuleContext) -> None:
        self.ctx = ctx
        if isinstance(ctx.clock, SimClock):
            self.lockstep = Lockstep(ctx.clock, ctx.workers, ctx.traffic)
        self.board.subscribe(ctx)
        ctx.subscribe(GoalStatus, self._on_goal_status)
        ctx.subscribe(Path, self._on_path)
        ctx.subscribe(ConfigApplied, self._on_config_answer)
        ctx.subscribe(ConfigRejected, self._on_config_answer)

    async def on_activate(self) -> None:
        tcp = self.ctx.config.tcp
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
        self.ctx.spawn(self._watch_staleness(), name="staleness")

    async def on_deactivate(self) -> None:
        if self._server is not None:
            self._server.close()
        for conn in list(self.connections):
            conn.close(
                "daemon stopping",
                {"type": "error", "field": "", "reason": "daemon stopping", "fatal": True},
            )
        if self._server is not None:
            await self._server.wait_closed()
            self._server = None

    @property
    def port(self) -> int:
        """The bound port (useful when the config asked for port 0 in tests)."""
        assert self._server is not None, "server not active"
        port: int = self._server.sockets[0].getsockname()[1]
        return port

    # --- connections --------------------------------------------------------------------

    def _new_connection(self) -> Connection:
        tcp = self.ctx.config.tcp
        return Connection(
            self,
            max_line_bytes=tcp.max_line_bytes,
            handshake_timeout_s=tcp.handshake_timeout_s,
            write_high_bytes=tcp.status_queue * STATUS_FRAME_BYTES,
        )

    def on_open(self, conn: Connection) -> bool:
        limit = self.ctx.config.tcp.max_clients
        if len(self.connections) >= limit:
            conn.close(
                "too many clients",
                {
                    "type": "error",
                    "field": "",
                    "fatal": True,
                    "reason": f"server full: {limit} clients connected (tcp.max_clients)",
                },
            )
            self.ctx.log.warning("client_refused", peer=conn.peer, reason="server full")
            return False
        self.connections.add(conn)
        return True

    def on_lines(self, conn: Connection, lines: list[bytes]) -> None:
        for index, line in enumerate(lines):
            if not conn.open:
                return
            session = conn.session
            if isinstance(session, Session) and session.kind in SENSOR_ROLES:
                self._sensor_lines(session, lines[index:])  # the fast path for data
                return
            if not line or line.isspace():
                continue  # blank lines are allowed (keep-alives, a person pressing enter)
            try:
                if session is None:
                    self._handshake(conn, line)
                else:
                    assert isinstance(session, Session)
                    if session.kind is DeviceKind.CLOCK:
                        self._clock(session, decode_clock(line))
                    else:
                        self._control(session, decode_control(line), self.ctx.clock.now())
            except Exception as err:
                self._reject(conn, line, err)

    def _reject(self, conn: Connection, line: bytes, err: Exception) -> None:
        """Answer a line that could not be used; the one supervised boundary per line."""
        session = conn.session
        if isinstance(session, Session):
            session.rejected += 1
        if isinstance(err, WireError):
            conn.send({"type": "error", "field": err.field, "reason": err.reason})
        elif isinstance(err, MessageError):
            conn.send({"type": "error", "field": "", "reason": str(err)})
        else:  # a bug, not bad input: counted against this module, the client is told
            self.ctx.bus.report_failure(self.name, {"peer": conn.peer, "line": line[:200]}, err)
            conn.send({"type": "error", "field": "", "reason": "internal error on this frame"})

    def on_close(self, conn: Connection, reason: str) -> None:
        self.connections.discard(conn)
        session = conn.session
        if not isinstance(session, Session):
            return
        for task in (session.status_task, session.clock_task):
            if task is not None:
                task.cancel()
        if session.kind in SENSOR_ROLES:
            self.ctx.traffic.add_received(session.device_id)  # the end counts as one line
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
            )
        )

    # --- handshake ----------------------------------------------------------------------

    def _handshake(self, conn: Connection, line: bytes) -> None:
        try:
            hello = decode_hello(line)
        except WireError as err:
            conn.close(
                "bad hello",
                {"type": "error", "field": err.field, "reason": err.reason, "fatal": True},
            )
            return
        token = self.ctx.config.tcp.token
        if token is not None and not hmac.compare_digest(
            (hello.token or "").encode(), token.encode()
        ):
            conn.close(
                "bad token",
                {
                    "type": "error",
                    "field": "token",
                    "fatal": True,
                    "reason": "missing or wrong token",
                },
            )
            self.ctx.log.warning("client_refused", peer=conn.peer, reason="bad token")
            return
        refusal = self._clock_refusal(hello.device_id) if hello.kind is DeviceKind.CLOCK else ""
        if refusal:
            conn.close(
                "clock refused",
                {"type": "error", "field": "role", "fatal": True, "reason": refusal},
            )
            self.ctx.log.warning("client_refused", peer=conn.peer, reason=refusal)
            return
        now = self.ctx.clock.now()
        old = self.sessions.get(hello.device_id)
        if old is not None:
            old.replaced = True
            old.conn.close(
                "replaced",
                {
                    "type": "error",
                    "field": "device_id",
                    "fatal": True,
                    "reason": "replaced by a new connection with this id",
                },
            )
            self.ctx.publish(
                DeviceLost(
                    stamp=now,
                    received=now,
                    device_id=old.device_id,
                    kind=old.kind,
                    reason="replaced by a new connection",
                )
            )
        session = Session(hello.device_id, hello.kind, conn, connected_s=now, last_rx_s=now)
        self.sessions[hello.device_id] = session
        conn.session = session
        conn.handshake_done()
        if hello.kind in SENSOR_ROLES:
            conn.coalesce_s = self.ctx.config.tcp.read_coalesce_ms / 1e3
        elif hello.kind is DeviceKind.CLOCK:
            session.clock_frames = asyncio.Queue(CLOCK_QUEUE)
            session.clock_task = self.ctx.spawn(
                self._run_clock(session), name=f"clock:{hello.device_id}"
            )
        conn.send(
            {
                "type": "welcome",
                "protocol": PROTOCOL_VERSION,
                "daemon": f"navd {__version__}",
                "device_id": hello.device_id,
                "role": hello.role,
                "max_line_bytes": self.ctx.config.tcp.max_line_bytes,
            }
        )
        self.ctx.log.info(
            "device_connected",
            device_id=hello.device_id,
            kind=hello.role,
            peer=conn.peer,
            replaced=old is not None,
        )
        self.ctx.publish(
            DeviceConnected(stamp=now, received=now, device_id=hello.device_id, kind=hello.kind)
        )

    # --- frames -------------------------------------------------------------------------

    def _sensor_lines(self, session: Session, lines: list[bytes]) -> None:
        """Lines from a sensor that arrived together: counted, then handled (at once, or on
        simulated time at the next step, in device order)."""
        count = sum(1 for line in lines if line and not line.isspace())
        handle = functools.partial(self._handle_sensor_lines, session, lines)
        self.ctx.traffic.take(session.device_id, count, handle)

    def _handle_sensor_lines(self, session: Session, lines: list[bytes]) -> None:
        """One arrival time, one staleness check for the batch."""
        now = self.ctx.clock.now()
        session.last_rx_s = now
        if session.stale:
            session.stale = False
            self.ctx.publish(
                DeviceResumed(
                    stamp=now, received=now, device_id=session.device_id, kind=session.kind
                )
            )
        conn, kind, device_id, stamps = (
            session.conn,
            session.kind,
            session.device_id,
            session.stamps,
        )
        publish = self.ctx.publish
        for line in lines:
            if not line or line.isspace():
                continue
            try:
                frame = decode_sensor(kind, line)
                if type(frame) is PingFrame:
                    conn.send({"type": "pong", "id": frame.id})
                    continue
                message = sensor_message(frame, device_id, stamps.to_daemon(frame.stamp, now), now)
            except Exception as err:
                self._reject(conn, line, err)
                continue
            session.accepted += 1
            if message is not None:
                publish(message)

    # --- the clock (a simulator in lockstep) ---------------------------------------------

    def _clock_refusal(self, device_id: str) -> str:
        """Why a clock client may not connect now ("" if it may)."""
        if self.lockstep is None:
            return (
                "this daemon runs on real time (lifecycle.clock = 'real'); start it with "
                "lifecycle.clock = 'simulated' to let a simulator drive its clock"
            )
        for session in self.sessions.values():
            if session.kind is DeviceKind.CLOCK and session.device_id != device_id:
                return (
                    f"clock client {session.device_id!r} already drives the time; one "
                    "simulator owns the clock"
                )
        return ""

    def _clock(self, session: Session, frame: ClockFrame | PingFrame) -> None:
        if isinstance(frame, PingFrame):
            session.conn.send({"type": "pong", "id": frame.id})
            return
        assert session.clock_frames is not None
        try:
            session.clock_frames.put_nowait(frame)
        except asyncio.QueueFull:
            raise WireError(
                "", f"{CLOCK_QUEUE} clock frames already waiting; wait for each clock_ack"
            ) from None
        session.accepted += 1

    async def _run_clock(self, session: Session) -> None:
        """Step the clock for each clock frame, in order, and answer each."""
        assert self.lockstep is not None and session.clock_frames is not None
        while session.conn.open:
            frame = await session.clock_frames.get()
            session.last_rx_s = self.ctx.clock.now()
            try:
                report = await self.lockstep.step_to(
                    frame.time, frame.frames, self.ctx.config.lifecycle.lockstep_timeout_s
                )
            except LifecycleError as err:
                session.rejected += 1
                session.conn.send({"type": "error", "field": "time", "reason": str(err)})
                continue
            answer: dict[str, object] = {
                "type": "clock_ack",
                "time": report.time_s,
                "sent": report.sent,
            }
            if report.missing:
                answer["missing"] = report.missing
                self.ctx.log.warning(
                    "lockstep_lines_missing",
                    time_s=report.time_s,
                    missing=report.missing,
                    waited_s=self.ctx.config.lifecycle.lockstep_timeout_s,
                )
            session.conn.send(answer)

    def _control(self, session: Session, frame: Any, now: float) -> None:
        session.accepted += 1
        session.requests += 1
        if isinstance(frame, PingFrame):
            session.conn.send({"type": "pong", "id": frame.id})
        elif isinstance(frame, SubscribeFrame):
            if session.status_task is not None:
                session.status_task.cancel()
            session.status_task = self.ctx.spawn(
                self._stream_status(session, frame.rate_hz), name=f"status:{session.device_id}"
            )
            session.conn.send({"type": "ack", "request": "subscribe", "rate_hz": frame.rate_hz})
        elif isinstance(frame, UnsubscribeFrame):
            if session.status_task is not None:
                session.status_task.cancel()
                session.status_task = None
            session.conn.send({"type": "ack", "request": "unsubscribe"})
        else:
            message = control_message(frame, session.device_id, now, session.requests)
            assert message is not None
            ack: dict[str, object] = {"type": "ack", "request": frame.type}
            if hasattr(message, "goal_id"):
                ack["goal_id"] = message.goal_id
            if isinstance(message, ConfigChange):
                ack["request_id"] = message.request_id
                self._config_requests[message.request_id] = session
            session.conn.send(ack)
            self.ctx.publish(message)

    # --- outgoing -----------------------------------------------------------------------

    def _on_config_answer(self, answer: ConfigApplied | ConfigRejected) -> None:
        session = self._config_requests.pop(answer.request_id, None)
        if session is None:
            return
        if isinstance(answer, ConfigApplied):
            session.conn.send(
                {
                    "type": "config_applied",
                    "request_id": answer.request_id,
                    "changed": list(answer.changed_keys),
                }
            )
        else:
            session.conn.send(
                {
                    "type": "config_rejected",
                    "request_id": answer.request_id,
                    "reason": answer.reason,
                }
            )

    def _on_goal_status(self, status: GoalStatus) -> None:
        self._to_controls({"type": "goal_status", **goal_dict(status)})

    def _on_path(self, path: Path) -> None:
        points = [[round(float(x), 3), round(float(y), 3)] for x, y in path.points_m]
        self._to_controls({"type": "path", "goal_id": path.goal_id, "points": points})

    def _to_controls(self, frame: dict[str, object]) -> None:
        """Send ``frame`` to every connected control client."""
        for session in self.sessions.values():
            if session.kind is DeviceKind.CONTROL:
                session.conn.send(frame)

    def status_frame(self) -> dict[str, object]:
        """The status a subscribed control client receives."""
        now = self.ctx.clock.now()
        devices: list[dict[str, object]] = [
            {
                "device_id": s.device_id,
                "kind": s.kind.value,
                "connected_s": round(now - s.connected_s, 3),
                "silent_s": round(now - s.last_rx_s, 3),
                "stale": s.stale,
                "accepted": s.accepted,
                "rejected": s.rejected,
            }
            for s in self.sessions.values()
        ]
        return self.board.frame(now, devices)

    async def _stream_status(self, session: Session, rate_hz: float) -> None:
        while session.conn.open:
            session.conn.send(self.status_frame(), droppable=True)
            await self.ctx.clock.sleep(1.0 / rate_hz)

    async def _watch_staleness(self) -> None:
        while True:
            await self.ctx.clock.sleep(STALE_CHECK_PERIOD_S)
            now = self.ctx.clock.now()
            tcp = self.ctx.config.tcp
            timeouts = {
                DeviceKind.LIDAR: tcp.lidar_timeout_s,
                DeviceKind.IMU: tcp.imu_timeout_s,
                DeviceKind.GPS: tcp.gps_timeout_s,
                DeviceKind.COMPASS: tcp.compass_timeout_s,
                DeviceKind.WHEEL_ODOMETRY: tcp.wheel_odometry_timeout_s,
            }
            for session in self.sessions.values():
                timeout = timeouts.get(session.kind)
                silent = now - session.last_rx_s
                if timeout is None or session.stale or silent <= timeout:
                    continue
                session.stale = True
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
                    )
                )
