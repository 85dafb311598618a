"""The live view's module ("viz"): a Foxglove WebSocket server fed from the bus.

Channels (topics) and what they carry:

- ``/map`` (foxglove.Grid): the SLAM map, at most ``viz.map_rate_hz``;
- ``/scan`` (foxglove.LaserScan): the latest scan in ``laser``, at most ``viz.scan_rate_hz``;
- ``/tf`` (foxglove.FrameTransforms): map -> odom -> base_link -> laser, with the pose;
- ``/pose`` (foxglove.Odometry): the fused pose with its covariance, at most
  ``viz.pose_rate_hz``;
- ``/route``, ``/goal``, ``/footprint``, ``/keep_out`` (foxglove.SceneUpdate): the global
  route, the goal, the robot's outline and the keep-out zones;
- ``/costmap`` (foxglove.Grid, ROS costmap values) and ``/trajectory`` (foxglove.SceneUpdate):
  the inflated costmap of the last plan (at most ``viz.map_rate_hz``) and the local
  planner's chosen rollout (at most ``viz.pose_rate_hz``), which the planner makes only
  while someone watches them (ViewInterest);
- ``/goal_status``, ``/status`` (JSON): the goal's progress, and the daemon's state (safety
  holds and their reasons, localization, module health, loop lag);
- ``/log`` (foxglove.Log): log lines at or above ``viz.log_level``;
- ``/page/...`` (JSON): the same state, small, for the operator page (see ``page_data``),
  which ``PageServer`` serves over HTTP on ``viz.page_port``.

Viewers steer by publishing on a channel of their own (see ``commands``): a goal, an
initial pose, a velocity or a cancel becomes the same bus message a TCP control client's
request does, so it passes the same safety gate; beyond loopback only with the token.

Nothing is encoded for a channel nobody subscribes to, so a daemon nobody watches pays for
a few attribute checks per message. What changes rarely (map, route, goal, outline, zones,
status) is sent again to a viewer when it subscribes, so it sees the whole state at once.
The server runs in its own threads (the SDK's); a port already in use is logged and the
daemon goes on without the view: watching is never a reason not to drive.
"""

from __future__ import annotations

import asyncio
import functools
import math
import secrets
import threading
import time
from collections.abc import Callable, Mapping
from typing import Any

import foxglove
from foxglove import Channel, Context, StatusLevel
from foxglove.channels import (
    FrameTransformsChannel,
    GridChannel,
    LaserScanChannel,
    LogChannel,
    OdometryChannel,
    SceneUpdateChannel,
)
from foxglove.messages import Log, LogLevel
from foxglove.websocket import (
    Capability,
    ChannelView,
    Client,
    ClientChannel,
    ServerListener,
    WebSocketServer,
)

from navd import __version__
from navd.drivers.convert import control_message
from navd.lifecycle.messages import (
    CostmapUpdate,
    DaemonStatus,
    DriveMode,
    Goal,
    GoalStatus,
    LaserScan,
    LocalizationState,
    LocalTrajectory,
    MapUpdate,
    Path,
    PoseEstimate,
    SafetyState,
    ViewInterest,
)
from navd.lifecycle.module import Module, ModuleContext
from navd.logs import add_log_tap, remove_log_tap
from navd.planning.zones import RECHECK_S, ZoneMasks
from navd.viz import page_data, scene
from navd.viz.commands import viewer_request
from navd.viz.errors import CommandRefusedError
from navd.viz.page_server import PageServer
from navd.viz.settings import VizSettings

__all__ = ["VizNode"]

_LOG_LEVELS = {
    "debug": LogLevel.Debug,
    "info": LogLevel.Info,
    "warning": LogLevel.Warning,
    "error": LogLevel.Error,
    "critical": LogLevel.Fatal,
}
_RANK = {"debug": 0, "info": 1, "warning": 2, "error": 3, "critical": 4}
# Fields of a log line that are not its details.
_LOG_META = frozenset({"event", "level", "timestamp", "component"})


# Viewer commands waiting for the event loop at most; more are dropped (a flooding viewer).
MAX_PENDING_COMMANDS = 64
# A viewer's refused commands are logged at most once per this many seconds each [s].
REFUSAL_LOG_PERIOD_S = 5.0


# A message may come this share of a period early and still be sent: a 10 Hz stream with
# jitter, capped at 10 Hz, keeps its 10 Hz, while on average no stream beats its cap.
JITTER_FRACTION = 0.2


class _Throttle:
    """At most one send per period [s] of the daemon clock on average: each send moves the
    next deadline a period on (the period is read at each ask, so a changed rate applies at
    once), and a message up to JITTER_FRACTION of a period early is on time."""

    def __init__(self) -> None:
        self._next = -math.inf

    def due(self, now: float, period_s: float) -> bool:
        if now < self._next - JITTER_FRACTION * period_s:
            return False
        self._next = max(self._next, now) + period_s
        return True


class _Listener(ServerListener):
    """Hears the server (in its threads) and hands on to the event loop: each subscription's
    topic to ``on_subscribe`` (and to ``on_unsubscribe`` when it ends, a viewer leaving
    included), each viewer's command with its topic to ``on_command``. At most
    MAX_PENDING_COMMANDS commands wait at once; a viewer flooding the server loses the rest
    (counted), never the loop's time."""

    def __init__(
        self,
        loop: asyncio.AbstractEventLoop,
        on_subscribe: Callable[[str], None],
        on_command: Callable[[int, str, bytes], None],
        on_unsubscribe: Callable[[str], None],
    ):
        self._loop = loop
        self._on_subscribe = on_subscribe
        self._on_unsubscribe = on_unsubscribe
        self._on_command = on_command
        self._topics: dict[tuple[int, int], str] = {}  # (client, its channel) -> topic
        self._lock = threading.Lock()
        self.pending = 0
        self.dropped = 0

    def on_subscribe(self, client: Client, channel: ChannelView) -> None:
        self._loop.call_soon_threadsafe(self._on_subscribe, channel.topic)

    def on_unsubscribe(self, client: Client, channel: ChannelView) -> None:
        self._loop.call_soon_threadsafe(self._on_unsubscribe, channel.topic)

    def on_client_advertise(self, client: Client, channel: ClientChannel) -> None:
        self._topics[(client.id, channel.id)] = channel.topic

    def on_client_unadvertise(self, client: Client, client_channel_id: int) -> None:
        self._topics.pop((client.id, client_channel_id), None)

    def on_message_data(self, client: Client, client_channel_id: int, data: bytes) -> None:
        topic = self._topics.get((client.id, client_channel_id), "")
        with self._lock:
            if self.pending >= MAX_PENDING_COMMANDS:
                self.dropped += 1
                return
            self.pending += 1
        self._loop.call_soon_threadsafe(self._command, client.id, topic, bytes(data))

    def _command(self, client_id: int, topic: str, data: bytes) -> None:
        with self._lock:
            self.pending -= 1
        self._on_command(client_id, topic, data)


def _finite(value: float) -> float | None:
    """JSON has no NaN: an unknown number is null."""
    return value if math.isfinite(value) else None


class VizNode(Module):
    """The live view module ("viz")."""

    def __init__(self) -> None:
        super().__init__("viz")
        self.server: WebSocketServer | None = None
        self._context: Context | None = None
        self._latest: dict[str, Callable[[], None]] = {}  # topic -> send its latest state
        self._status: dict[str, Any] = {}
        self._offset_s = 0.0  # [s] wall clock minus daemon clock, fixed at activation
        self._listener: _Listener | None = None
        # This run's command token: the operator page on this machine gets it (PageServer).
        self.command_token = secrets.token_urlsafe(24)
        self.page: PageServer | None = None
        self._pose: PoseEstimate | None = None  # the latest, to place the page's scan
        self._page_map: tuple[MapUpdate, dict[str, Any]] | None = None  # the last built
        self._commands_taken = 0
        self._refused_logged: dict[int, float] = {}  # viewer -> when its last refusal was logged
        self.refused = 0  # commands refused, for the status and tests

    @property
    def port(self) -> int | None:
        """The bound port (None when the view is not serving)."""
        return None if self.server is None else self.server.port

    # --- lifecycle --------------------------------------------------------------------

    async def on_configure(self, ctx: ModuleContext) -> None:
        self.ctx = ctx
        self.settings = ctx.settings(VizSettings, self._settings_changed)
        self._map_throttle = _Throttle()
        self._scan_throttles: dict[str, _Throttle] = {}  # by lidar
        self._pose_throttle = _Throttle()
        ctx.subscribe(MapUpdate, self._on_map)
        ctx.subscribe(LaserScan, self._on_scan)
        ctx.subscribe(PoseEstimate, self._on_pose)
        ctx.subscribe(Path, self._on_path)
        ctx.subscribe(Goal, self._on_goal)
        ctx.subscribe(GoalStatus, self._on_goal_status)
        ctx.subscribe(DaemonStatus, self._on_daemon_status)
        ctx.subscribe(LocalizationState, self._on_localization)
        ctx.subscribe(SafetyState, self._on_safety)
        ctx.subscribe(DriveMode, self._on_drive_mode)
        ctx.subscribe(CostmapUpdate, self._on_costmap)
        ctx.subscribe(LocalTrajectory, self._on_trajectory)
        # The channels exist from here on, so a message before activation finds them (it is
        # kept, and sent to whoever subscribes once the server runs).
        context = Context()
        self._context = context
        self.map = GridChannel("/map", context=context)
        self.scan = LaserScanChannel("/scan", context=context)
        self.tf = FrameTransformsChannel("/tf", context=context)
        self.pose = OdometryChannel("/pose", context=context)
        self.route = SceneUpdateChannel("/route", context=context)
        self.goal = SceneUpdateChannel("/goal", context=context)
        self.footprint = SceneUpdateChannel("/footprint", context=context)
        self.keep_out = SceneUpdateChannel("/keep_out", context=context)
        # the zone masks (docs/planning.md) as grids: keep-out 100, speed 1..100 % of top speed
        self.keep_out_mask = GridChannel("/zones/keep_out", context=context)
        self.speed_mask = GridChannel("/zones/speed", context=context)
        self.goal_status = Channel("/goal_status", context=context)
        self.status = Channel("/status", context=context)
        self.log = LogChannel("/log", context=context)
        # Made by the planner only while someone watches (see ViewInterest).
        self.costmap = GridChannel("/costmap", context=context)
        self.trajectory = SceneUpdateChannel("/trajectory", context=context)
        # The operator page's own channels (JSON: a phone decodes it natively).
        self.page_info = Channel("/page/info", context=context)
        self.page_map = Channel("/page/map", context=context)
        self.page_pose = Channel("/page/pose", context=context)
        self.page_scan = Channel("/page/scan", context=context)
        self.page_route = Channel("/page/route", context=context)
        self.page_goal = Channel("/page/goal", context=context)
        self._channels: tuple[Any, ...] = (
            self.map,
            self.scan,
            self.tf,
            self.pose,
            self.route,
            self.goal,
            self.footprint,
            self.keep_out,
            self.goal_status,
            self.status,
            self.log,
            self.costmap,
            self.trajectory,
            self.page_info,
            self.page_map,
            self.page_pose,
            self.page_scan,
            self.page_route,
            self.page_goal,
        )
        self._page_scan_throttles: dict[str, _Throttle] = {}  # by lidar
        self._costmap_throttle = _Throttle()
        self._trajectory_throttle = _Throttle()
        self._watchers: dict[str, int] = {}  # topic -> subscriptions now
        self._page_pose_throttle = _Throttle()
        self._map_pending: MapUpdate | None = None
        # The gate starts free and says each hold and release, all heard from here on.
        self._status["safety"] = {"stopped": False, "reasons": []}

    async def on_activate(self) -> None:
        s = self.settings.value
        context = self._context
        assert context is not None
        now = self.ctx.clock.now()
        self._offset_s = time.time() - now
        self._remember("/footprint", lambda: self._send_footprint(now))
        self._remember("/keep_out", lambda: self._send_keep_out(now))
        self._zones: ZoneMasks | None = None
        self._zones_shown = -1
        self.ctx.every(RECHECK_S, self._check_zones, name="zone-masks")
        self._remember("/page/info", self._send_page_info)
        listener = _Listener(
            asyncio.get_running_loop(), self._subscribed, self._on_command, self._unsubscribed
        )
        self._listener = listener
        try:
            self.server = foxglove.start_server(
                name=f"navd {__version__} ({s.robot_name})",
                host=s.host,
                port=s.port,
                context=context,
                server_listener=listener,
                capabilities=[Capability.ClientPublish],
                supported_encodings=["json"],
            )
        except Exception as err:  # the SDK reports a busy port or a bad address as RuntimeError
            self.ctx.log.error(
                "viz_unavailable",
                host=s.host,
                port=s.port,
                error=str(err),
                fix="if another program (another navd?) holds the port, change viz.port; check "
                "viz.host is an address of this machine; or set viz.enabled = false. navd "
                "drives on without the live view",
            )
            return
        add_log_tap(self._on_log_line)
        self.ctx.every(lambda: self.settings.value.map_period_s, self._flush_map, name="viz-map")
        self.ctx.log.info("viz_listening", host=s.host, port=self.server.port)
        if s.page_enabled:
            self._serve_page(s, self.server.port)

    def _serve_page(self, s: VizSettings, ws_port: int) -> None:
        """Start the operator page's HTTP server (its own thread); a port that cannot be
        bound leaves the Foxglove stream serving."""
        try:
            self.page = PageServer(s.host, s.page_port, ws_port, s.robot_name, self.command_token)
        except OSError as err:
            self.ctx.log.error(
                "page_unavailable",
                host=s.host,
                port=s.page_port,
                error=str(err),
                fix="if another program holds the port, change viz.page_port; or set "
                "viz.page_enabled = false. The Foxglove stream goes on",
            )
            return
        shown = "127.0.0.1" if s.host in ("0.0.0.0", "::") else s.host
        self.ctx.log.info("page_listening", url=f"http://{shown}:{self.page.port}/")

    def settings_in_use(self) -> tuple[object, ...]:
        """The view reads its settings at every message: the holder's value is in use."""
        return (self.settings.value,)

    def _settings_changed(self, old: VizSettings, new: VizSettings) -> None:
        """Rates apply at the next message; a new outline or new zones are shown at once."""
        if self.server is None:
            return
        now = self.ctx.clock.now()
        if new.footprint != old.footprint:
            self._remember("/footprint", lambda: self._send_footprint(now))
        if new.keep_out_zones != old.keep_out_zones:
            self._remember("/keep_out", lambda: self._send_keep_out(now))
        self._remember("/page/info", self._send_page_info)

    async def on_deactivate(self) -> None:
        remove_log_tap(self._on_log_line)
        if self.page is not None:
            page, self.page = self.page, None
            await asyncio.to_thread(page.stop)  # waits up to a poll interval: off the loop
        if self.server is not None:
            self.server.stop()
            self.server = None

    async def on_cleanup(self) -> None:
        for channel in self._channels:
            channel.close()
        self._latest.clear()  # the last map and route are not held past the view's life
        self._status.clear()
        self._map_pending = None
        self._pose = None
        self._page_map = None
        self._context = None

    # --- state a new viewer gets at once ----------------------------------------------

    def _remember(self, topic: str, send: Callable[[], None]) -> None:
        """Keep how to send ``topic``'s latest state, and send it now if anyone watches."""
        self._latest[topic] = send
        send()

    def _subscribed(self, topic: str) -> None:
        """Event loop: a viewer subscribed to ``topic``; it gets the latest state."""
        self._count(topic, +1)
        send = self._latest.get(topic)
        if send is not None:
            send()

    def _unsubscribed(self, topic: str) -> None:
        self._count(topic, -1)

    def _count(self, topic: str, change: int) -> None:
        """Keep the subscriptions of ``topic``; tell the planner when the costmap or the
        trajectory gains its first watcher or loses its last."""
        before = self._watchers.get(topic, 0)
        self._watchers[topic] = max(before + change, 0)
        if topic in ("/costmap", "/trajectory") and (before > 0) != (self._watchers[topic] > 0):
            now = self.ctx.clock.now()
            self.ctx.publish(
                ViewInterest(
                    stamp=now,
                    received=now,
                    costmap=self._watchers.get("/costmap", 0) > 0,
                    trajectory=self._watchers.get("/trajectory", 0) > 0,
                )
            )

    # --- handlers (event loop; cheap unless someone watches) --------------------------

    def _on_map(self, update: MapUpdate) -> None:
        self._map_pending = update  # the newest is kept, so the last change is never lost
        self._flush_map(update.stamp)

    def _flush_map(self, now: float) -> None:
        """Send the newest map if it has not gone out and the map's rate allows it now (also
        on a timer: a change that came too soon goes out when its turn comes)."""
        update = self._map_pending
        if update is None or not self._map_throttle.due(now, self.settings.value.map_period_s):
            return
        self._map_pending = None
        self._remember("/map", lambda: self._send_map(update))
        self._remember("/page/map", lambda: self._send_page_map(update))

    def _send_page_map(self, update: MapUpdate) -> None:
        """The page's map, built in a worker (coarsening a large map takes tens of ms) once
        per map: a viewer subscribing later gets the same message."""
        if self.server is None or not self.page_map.has_sinks():
            return
        built = self._page_map
        if built is not None and built[0] is update:
            self.page_map.log(built[1], log_time=self._log_time())
            return
        log_time = self._log_time()

        def job() -> None:
            message = page_data.map_message(update)
            self._page_map = (update, message)
            self.page_map.log(message, log_time=log_time)  # the SDK's channels take any thread

        self.ctx.submit("viz_page_map", job)

    def _log_time(self) -> int:
        """[ns] now, on the wall clock as the view shows it."""
        return scene.nanoseconds(self.ctx.clock.now() + self._offset_s)

    def _send_map(self, update: MapUpdate) -> None:
        if self.map.has_sinks():
            grid = scene.occupancy_grid(update, offset_s=self._offset_s)
            self.map.log(grid, log_time=self._log_time())

    def _on_scan(self, scan: LaserScan) -> None:
        if self.server is None:
            return
        settings = self.settings.value
        period_s, lidar = settings.scan_period_s, scan.device_id
        mount = settings.mounts.lidar(lidar)
        throttle = self._scan_throttles.setdefault(lidar, _Throttle())
        if self.scan.has_sinks() and throttle.due(scan.received, period_s):
            shown = scene.laser_scan(scan, mount, offset_s=self._offset_s)
            self.scan.log(shown, log_time=self._log_time())
        pose = self._pose
        page_throttle = self._page_scan_throttles.setdefault(lidar, _Throttle())
        if (
            pose is not None
            and self.page_scan.has_sinks()
            and page_throttle.due(scan.received, max(period_s, page_data.PAGE_SCAN_PERIOD_S))
        ):
            self._send_json(self.page_scan, page_data.scan_message(scan, pose, mount))

    def _on_pose(self, pose: PoseEstimate) -> None:
        self._pose = pose
        if (
            self.server is not None
            and self.page_pose.has_sinks()
            and self._page_pose_throttle.due(
                pose.received, max(self.settings.value.pose_period_s, page_data.PAGE_POSE_PERIOD_S)
            )
        ):
            self._send_json(self.page_pose, page_data.pose_message(pose))
        if self.server is None or not (self.tf.has_sinks() or self.pose.has_sinks()):
            return
        if not self._pose_throttle.due(pose.received, self.settings.value.pose_period_s):
            return
        t, offset = self._log_time(), self._offset_s
        if self.tf.has_sinks():
            lidar = self.settings.value.mounts.default_lidar.pose
            self.tf.log(scene.frame_tree(pose, lidar, offset_s=offset), log_time=t)
        if self.pose.has_sinks():
            self.pose.log(scene.odometry(pose, offset_s=offset), log_time=t)

    def _on_path(self, path: Path) -> None:
        self._remember(
            "/route",
            lambda: self._send_scene(self.route, scene.route_scene(path, offset_s=self._offset_s)),
        )
        self._remember(
            "/page/route",
            lambda: self._send_json_of(self.page_route, page_data.route_message, path),
        )

    def _on_goal(self, goal: Goal) -> None:
        self._remember(
            "/goal",
            lambda: self._send_scene(self.goal, scene.goal_scene(goal, offset_s=self._offset_s)),
        )
        self._remember(
            "/page/goal", lambda: self._send_json_of(self.page_goal, page_data.goal_message, goal)
        )

    def _on_costmap(self, update: CostmapUpdate) -> None:
        if self._costmap_throttle.due(update.stamp, self.settings.value.map_period_s):
            self._remember(
                "/costmap",
                lambda: self._send_grid(self.costmap, update),
            )

    def _send_grid(self, channel: GridChannel, update: CostmapUpdate) -> None:
        if self.server is not None and channel.has_sinks():
            channel.log(
                scene.occupancy_grid(update, offset_s=self._offset_s), log_time=self._log_time()
            )

    def _on_trajectory(self, trajectory: LocalTrajectory) -> None:
        if self._trajectory_throttle.due(trajectory.stamp, self.settings.value.pose_period_s):
            shown = scene.trajectory_scene(trajectory, offset_s=self._offset_s)
            self._send_scene(self.trajectory, shown)

    def _send_page_info(self) -> None:
        self._send_json(self.page_info, page_data.info_message(self.settings.value))

    def _send_footprint(self, now: float) -> None:
        footprint = self.settings.value.footprint
        self._send_scene(self.footprint, scene.footprint_scene(footprint, now + self._offset_s))

    def _check_zones(self, now: float) -> None:
        """Read the zone masks in a worker when the config names others or their files
        change; show what changed (the last reading stays for later viewers)."""
        paths = self.settings.value.zone_masks
        zones = self._zones
        if zones is None and paths == (None, None):
            return

        def job() -> None:
            current = self._zones
            if current is None or current.paths != paths:
                current = self._zones = ZoneMasks(*paths)
            else:
                current.refresh(now)
            if current.revision == self._zones_shown:
                return
            self._zones_shown = current.revision
            for topic, channel, mask in (
                ("/zones/keep_out", self.keep_out_mask, current.keep_out),
                ("/zones/speed", self.speed_mask, current.speed),
            ):
                if mask is not None:
                    grid = scene.zone_grid(mask.frame, mask.values, now + self._offset_s)
                    self._latest[topic] = functools.partial(self._send_zone, channel, grid)
                    self._send_zone(channel, grid)

        self.ctx.submit("viz_zones", job)

    def _send_zone(self, channel: GridChannel, grid: Any) -> None:
        if self.server is not None and channel.has_sinks():
            channel.log(grid, log_time=self._log_time())

    def _send_keep_out(self, now: float) -> None:
        zones = self.settings.value.keep_out_zones
        self._send_scene(self.keep_out, scene.keep_out_scene(zones, now + self._offset_s))

    def _send_scene(self, channel: SceneUpdateChannel, update: Any) -> None:
        if self.server is not None and channel.has_sinks():
            channel.log(update, log_time=self._log_time())

    def _on_goal_status(self, status: GoalStatus) -> None:
        message = {
            "stamp": status.stamp,
            "goal_id": status.goal_id,
            "state": status.state,
            "distance_remaining_m": _finite(status.distance_remaining_m),
            "eta_s": _finite(status.eta_s),
            "reason": status.reason,
        }
        self._remember("/goal_status", lambda: self._send_json(self.goal_status, message))

    def _on_daemon_status(self, status: DaemonStatus) -> None:
        self._status.update(
            stamp=status.stamp,
            uptime_s=round(status.uptime_s, 3),
            loop_lag_max_ms=round(status.loop_lag_max_ms, 3),
            safe_stop_reasons=list(status.safe_stop_reasons),
            modules={
                m.name: {"state": m.state, "faulted": m.faulted, "failures": m.handler_failures}
                for m in status.modules
            },
        )
        self._send_status()

    def _on_localization(self, state: LocalizationState) -> None:
        self._status["localization"] = {
            "state": state.state,
            "position_std_m": _finite(state.position_std_m),
            "yaw_std_rad": _finite(state.yaw_std_rad),
        }
        self._send_status()

    def _on_drive_mode(self, mode: DriveMode) -> None:
        self._status["drive"] = {"mode": mode.mode, "operator": mode.operator}
        self._send_status()

    def _on_safety(self, state: SafetyState) -> None:
        self._status["safety"] = {"stopped": bool(state.reasons), "reasons": list(state.reasons)}
        self._send_status()

    def _send_status(self) -> None:
        snapshot = dict(self._status)
        self._remember("/status", lambda: self._send_json(self.status, snapshot))

    def _send_json(self, channel: Channel, message: Mapping[str, Any]) -> None:
        if self.server is not None and channel.has_sinks():
            channel.log(dict(message), log_time=self._log_time())

    def _send_json_of(
        self, channel: Channel, build: Callable[[Any], Mapping[str, Any]], source: Any
    ) -> None:
        """Send ``build(source)``, built only when someone watches ``channel``."""
        if self.server is not None and channel.has_sinks():
            channel.log(dict(build(source)), log_time=self._log_time())

    # --- commands from viewers (event loop) ----------------------------------------------

    def _on_command(self, client_id: int, topic: str, data: bytes) -> None:
        """A viewer published ``data`` on ``topic``: the same request a control client could
        send, published on the bus (and so through the safety gate), or refused with why."""
        operator = f"viewer-{client_id}"
        try:
            frame = viewer_request(topic, data, self.settings.value, self.command_token)
        except CommandRefusedError as err:
            self._refuse(client_id, topic, str(err))
            return
        self._commands_taken += 1
        now = self.ctx.clock.now()
        self.ctx.publish(control_message(frame, operator, now, self._commands_taken))

    def _refuse(self, client_id: int, topic: str, reason: str) -> None:
        self.refused += 1
        now = self.ctx.clock.now()
        if now - self._refused_logged.get(client_id, -math.inf) >= REFUSAL_LOG_PERIOD_S:
            self._refused_logged[client_id] = now
            self.ctx.log.warning(
                "viewer_command_refused", viewer=client_id, topic=topic, reason=reason
            )
        if self.server is not None:  # the viewer sees why in its problems panel
            self.server.publish_status(
                f"command on {topic} refused: {reason}", StatusLevel.Warning, id="navd-command"
            )

    # --- log lines (any thread) ---------------------------------------------------------

    def _on_log_line(self, event: Mapping[str, Any]) -> None:
        if not self.log.has_sinks():
            return
        level = str(event.get("level", "info"))
        if _RANK.get(level, 1) < _RANK[self.settings.value.log_level]:
            return
        details = " ".join(f"{k}={v}" for k, v in event.items() if k not in _LOG_META)
        text = str(event.get("event", ""))
        wall_s = self.ctx.clock.now() + self._offset_s
        self.log.log(
            Log(
                timestamp=scene.as_timestamp(wall_s),
                level=_LOG_LEVELS.get(level, LogLevel.Unknown),
                message=f"{text} {details}" if details else text,
                name=str(event.get("component", "navd")),
            ),
            log_time=scene.nanoseconds(wall_s),
        )
