"""The control role: goals, cancels, config changes and reads, initial poses, map saves,
recordings and driving by hand from a client, each acknowledged (driving excepted); status
streams; goal progress and routes sent to every control client.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable

from navd.drivers.tcp.session import Server, Session
from navd.drivers.tcp.settings import readable_config
from navd.drivers.tcp.status_board import goal_info
from navd.lifecycle.messages import (
    CancelGoal,
    ConfigApplied,
    ConfigChange,
    ConfigRejected,
    DeviceKind,
    GeoGoal,
    Goal,
    GoalStatus,
    InitialPose,
    LoadMapRequest,
    ManualCommand,
    MapLoaded,
    MapSaved,
    MapUpdate,
    MissionRequest,
    MissionStatus,
    Path,
    PoseFound,
    SaveMapRequest,
)
from navd.lifecycle.requests import control_message
from navd.wire import (
    Ack,
    ConfigAppliedFrame,
    ConfigGetFrame,
    ConfigRejectedFrame,
    GoalStatusFrame,
    MapLoadedFrame,
    MapSavedFrame,
    MissionStatusFrame,
    PathFrame,
    PingFrame,
    Pong,
    PoseFoundFrame,
    ReplyPart,
    StatusFrame,
    SubscribeFrame,
    UnsubscribeFrame,
    WireError,
    decode_control,
    encode,
)

__all__ = ["ControlRole"]

# An initial pose may lie this far beyond the mapped area [m] (a robot just outside it).
INITIAL_POSE_MARGIN_M = 20.0


class ControlRole:
    """Handles every control session of the server.

    Args:
        server: the server.
        sessions: the sessions connected now (goal progress and routes go to every control
            session among them).
        status: builds the status frame a subscriber receives.
        allow_privileged: whether control clients may change privileged config keys now.
        teleop_enabled: whether control clients may drive by hand now.
    """

    def __init__(
        self,
        server: Server,
        sessions: Callable[[], Iterable[Session]],
        status: Callable[[], StatusFrame],
        allow_privileged: Callable[[], bool],
        teleop_enabled: Callable[[], bool],
    ) -> None:
        self._server = server
        self._sessions = sessions
        self._status = status
        self._allow_privileged = allow_privileged
        self._teleop_enabled = teleop_enabled
        self._config_requests: dict[str, Session] = {}
        self._map_area: tuple[float, float, float, float] | None = None  # [m] x0, y0, x1, y1
        ctx = server.ctx
        self._readable = ctx.settings(readable_config)  # what config_get answers from
        ctx.subscribe(GoalStatus, self._on_goal_status)
        ctx.subscribe(MissionStatus, self._on_mission_status)
        ctx.subscribe(Path, self._on_path)
        ctx.subscribe(ConfigApplied, self._on_config_answer)
        ctx.subscribe(ConfigRejected, self._on_config_answer)
        ctx.subscribe(MapSaved, self._on_map_saved)
        ctx.subscribe(MapLoaded, self._on_map_loaded)
        ctx.subscribe(PoseFound, self._on_pose_found)
        ctx.subscribe(MapUpdate, self._on_map)

    def opened(self, session: Session) -> None:
        """Nothing to start until the client subscribes."""

    def lines(self, session: Session, lines: list[bytes]) -> None:
        session.heard(self._server.ctx.clock.now())  # any line, a blank one too, is not idle
        self._server.each_line(session, lines, lambda line: self._request(session, line))

    def closed(self, session: Session) -> None:
        if session.status_task is not None:
            session.status_task.cancel()
        for request_id in [r for r, s in self._config_requests.items() if s is session]:
            del self._config_requests[request_id]  # its answer has nobody to go to

    def _request(self, session: Session, line: bytes) -> None:
        frame = decode_control(line)
        session.accepted += 1
        session.requests += 1
        conn = session.conn
        if isinstance(frame, PingFrame):
            conn.send(Pong(id=frame.id))
        elif isinstance(frame, SubscribeFrame):
            if session.status_task is not None:
                session.status_task.cancel()
            session.status_task = self._server.ctx.spawn(
                self._stream_status(session, frame.rate_hz), name=f"status:{session.device_id}"
            )
            conn.send(Ack(request=frame.type, rate_hz=frame.rate_hz))
        elif isinstance(frame, ConfigGetFrame):
            conn.send(Ack(request=frame.type, key=frame.key, value=self._config_value(frame.key)))
        elif isinstance(frame, UnsubscribeFrame):
            if session.status_task is not None:
                session.status_task.cancel()
                session.status_task = None
            conn.send(Ack(request=frame.type))
            self._server.wake_watch()  # its idle time counts from now
        else:
            now = self._server.ctx.clock.now()
            privileged = self._allow_privileged()
            message = control_message(
                frame, session.device_id, now, session.requests, privileged=privileged
            )
            if isinstance(message, InitialPose):
                self._check_on_map(message)
            if isinstance(message, SaveMapRequest | LoadMapRequest) and message.folder:
                self._check_folder(privileged)
            if isinstance(message, ManualCommand):
                # a stream, like a sensor's: not acknowledged, errors are answered
                if not self._teleop_enabled():
                    raise WireError("type", "teleop.enabled is false: driving by hand is off")
            elif isinstance(message, ConfigChange):
                self._config_requests[message.request_id] = session
                conn.send(Ack(request=frame.type, request_id=message.request_id))
            else:
                goal_id = (
                    message.goal_id if isinstance(message, Goal | GeoGoal | CancelGoal) else None
                )
                mission_id = message.mission_id if isinstance(message, MissionRequest) else None
                conn.send(Ack(request=frame.type, goal_id=goal_id, mission_id=mission_id))
            self._server.ctx.publish(message)

    async def _stream_status(self, session: Session, rate_hz: float) -> None:
        clock = self._server.ctx.clock
        while session.conn.open:
            session.conn.send(self._status(), droppable=True)
            await clock.sleep(1.0 / rate_hz)

    def _config_value(self, key: str) -> object:
        """The running config's value at ``key`` (a section as a table), secrets redacted.

        Raises:
            WireError: naming the sections, or the section's keys, when ``key`` is unknown.
        """
        plain = self._readable.value
        section, _, name = key.partition(".")
        if section not in plain:
            raise WireError("key", f"no section {section!r}; sections: {', '.join(plain)}")
        if not name:
            return plain[section]
        if name not in plain[section]:
            known = ", ".join(plain[section])
            raise WireError("key", f"no key {name!r} in section {section!r}; its keys: {known}")
        return plain[section][name]

    def _on_config_answer(self, answer: ConfigApplied | ConfigRejected) -> None:
        session = self._config_requests.pop(answer.request_id, None)
        if session is None:
            return
        if isinstance(answer, ConfigApplied):
            session.conn.send(
                ConfigAppliedFrame(request_id=answer.request_id, changed=list(answer.changed_keys))
            )
        else:
            session.conn.send(
                ConfigRejectedFrame(request_id=answer.request_id, reason=answer.reason)
            )

    def _on_map(self, update: MapUpdate) -> None:
        rows, cols = update.occupancy.shape
        x0, y0, res = update.origin_x_m, update.origin_y_m, update.resolution_m
        self._map_area = (x0, y0, x0 + cols * res, y0 + rows * res)

    def _check_folder(self, privileged: bool) -> None:
        """Refuse a map folder of the robot's disk unless the config trusts control clients
        with privileged changes (``slam.map_dir`` itself is a privileged key).

        Raises:
            WireError: on the ``folder`` field.
        """
        if not privileged:
            raise WireError(
                "folder",
                "a folder other than slam.map_dir is privileged: set "
                "tcp.allow_privileged_changes = true in the config, or leave it out to use "
                "slam.map_dir",
            )

    def _check_on_map(self, pose: InitialPose) -> None:
        """Refuse an initial pose far from the map: SLAM would search for the robot there,
        or grow its map out to it.

        Raises:
            WireError: naming the map's extent.
        """
        area = self._map_area
        if area is None:
            return  # no map yet: the pose is where the map will start
        x0, y0, x1, y1 = area
        outside_x = max(x0 - pose.x_m, pose.x_m - x1, 0.0)
        outside_y = max(y0 - pose.y_m, pose.y_m - y1, 0.0)
        outside_m = max(outside_x, outside_y)
        if outside_m > INITIAL_POSE_MARGIN_M:
            raise WireError(
                "x" if outside_x >= outside_y else "y",
                f"({pose.x_m:.1f}, {pose.y_m:.1f}) m lies {outside_m:.0f} m outside the map "
                f"(x {x0:.1f}..{x1:.1f}, y {y0:.1f}..{y1:.1f}); give a pose on the map",
            )

    def _on_mission_status(self, status: MissionStatus) -> None:
        self._broadcast(MissionStatusFrame.of(status.info))

    def _on_goal_status(self, status: GoalStatus) -> None:
        self._broadcast(GoalStatusFrame.of(goal_info(status)))

    def _on_map_saved(self, saved: MapSaved) -> None:
        self._broadcast(
            MapSavedFrame(
                name=saved.name, path=saved.path, reason=saved.reason, files=list(saved.files)
            )
        )

    def _on_map_loaded(self, loaded: MapLoaded) -> None:
        self._broadcast(MapLoadedFrame(name=loaded.name, path=loaded.path, reason=loaded.reason))

    def _on_pose_found(self, found: PoseFound) -> None:
        self._broadcast(
            PoseFoundFrame(
                x=round(found.x_m, 4),
                y=round(found.y_m, 4),
                yaw=round(found.yaw_rad, 4),
                score=round(found.score, 4),
                whole_map=found.whole_map,
            )
        )

    def _on_path(self, path: Path) -> None:
        points = [(round(float(x), 3), round(float(y), 3)) for x, y in path.points_m]
        self._broadcast(PathFrame(goal_id=path.goal_id, points=points))

    def _broadcast(self, frame: ReplyPart) -> None:
        """Send ``frame`` to every connected control client (encoded once)."""
        line = encode(frame)
        for session in self._sessions():
            if session.kind is DeviceKind.CONTROL:
                session.conn.send_line(line)
