"""The live view's module ("viz"): a Foxglove WebSocket server fed from the bus.

Channels (topics) and what they carry:

- ``/map`` (foxglove.Grid): the SLAM map, at most ``viz.map_rate_hz``;
- ``/scan`` (foxglove.LaserScan): the latest scan in ``laser``, at most ``viz.scan_rate_hz``;
- ``/tf`` (foxglove.FrameTransforms): map -> odom -> base_link -> laser, with the pose;
- ``/pose`` (foxglove.Odometry): the fused pose with its covariance, at most
  ``viz.pose_rate_hz``; ``/pose/in_frame`` (foxglove.PoseInFrame) the same for Lichtblick;
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

The robot's state (pose, goal progress, safety, localization, who drives, the daemon's
health) comes as ``RobotState`` from the lifecycle's ``StateView``; the streams (map, scans,
route, goal, costmap, trajectory) as their own messages. ``channels`` holds the channels,
``listener`` hears the server's threads, ``sender`` sends (and remembers the latest state
of each topic), ``status_feed``, ``zone_feed`` and ``log_feed`` write the JSON status, the
zone masks and the log.

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
import time

from foxglove import Context, StatusLevel
from foxglove.websocket import Capability, WebSocketServer

from navd import __version__
from navd.lifecycle import Module, ModuleContext, control_message
from navd.lifecycle.messages import (
    CostmapUpdate,
    Goal,
    LaserScan,
    LocalTrajectory,
    MapUpdate,
    Path,
    PoseEstimate,
    RobotState,
    ViewInterest,
)
from navd.logs import add_log_tap, remove_log_tap
from navd.planning import RECHECK_S
from navd.viz import scene
from navd.viz.channels import LiveChannels
from navd.viz.commands import viewer_request
from navd.viz.errors import CommandRefusedError
from navd.viz.listener import Throttle, ViewerListener
from navd.viz.log_feed import LogFeed
from navd.viz.page_feed import PageFeed
from navd.viz.page_server import PageServer
from navd.viz.sender import Sender
from navd.viz.settings import VizSettings
from navd.viz.status_feed import STATUS_PARTS, goal_status_message, status_message
from navd.viz.viewer_gate import ViewerGate, serve_viewers
from navd.viz.zone_feed import ZoneFeed

__all__ = ["VizNode"]

# A viewer's refused commands are logged at most once per this many seconds each [s].
REFUSAL_LOG_PERIOD_S = 5.0


class VizNode(Module):
    """The live view module ("viz")."""

    def __init__(self) -> None:
        super().__init__("viz")
        self.server: WebSocketServer | None = None
        self._gate: ViewerGate  # in front of the server while it runs
        self._listener: ViewerListener | None = None
        # This run's command token: the operator page on this machine gets it (PageServer).
        self.command_token = secrets.token_urlsafe(24)
        self.page: PageServer | None = None
        self._commands_taken = 0
        self._refused_logged: dict[int, float] = {}  # viewer -> when its last refusal was logged
        self.refused = 0  # commands refused, for the status and tests

    @property
    def port(self) -> int | None:
        """The bound port (None when the view is not serving)."""
        return None if self.server is None else self._gate.port

    # --- lifecycle --------------------------------------------------------------------

    async def on_configure(self, ctx: ModuleContext) -> None:
        self.ctx = ctx
        self.settings = ctx.settings(VizSettings.from_config, self._settings_changed)
        self._map_throttle = Throttle()
        self._scan_throttles: dict[str, Throttle] = {}  # by lidar
        self._pose_throttle = Throttle()
        self._costmap_throttle = Throttle()
        self._trajectory_throttle = Throttle()
        self._watchers: dict[str, int] = {}  # topic -> subscriptions now
        self._map_pending: MapUpdate | None = None
        ctx.subscribe(RobotState, self._on_state)
        ctx.subscribe(MapUpdate, self._on_map)
        ctx.subscribe(LaserScan, self._on_scan)
        ctx.subscribe(Path, self._on_path)
        ctx.subscribe(Goal, self._on_goal)
        ctx.subscribe(CostmapUpdate, self._on_costmap)
        ctx.subscribe(LocalTrajectory, self._on_trajectory)
        self.channels = channels = LiveChannels(Context())
        self.sender = Sender(ctx.clock, lambda: self.server is not None)
        self._zones = ZoneFeed(
            self.sender,
            channels.keep_out_mask,
            channels.speed_mask,
            lambda job: ctx.submit("viz_zones", job),
        )
        self._page = PageFeed(self.sender, channels, lambda job: ctx.submit("viz_page_map", job))
        self._log_feed = LogFeed(
            channels.log,
            lambda: self.settings.value.log_level,
            lambda: self.ctx.clock.now() + self.sender.offset_s,
        )
        # The gate starts free and says each hold and release, all heard from here on.
        self._send_status(RobotState(stamp=0.0, received=0.0, changed=frozenset()))

    async def on_activate(self) -> None:
        s = self.settings.value
        now = self.ctx.clock.now()
        self.sender.offset_s = time.time() - now
        self.sender.remember("/footprint", lambda: self._send_footprint(now))
        self.sender.remember("/keep_out", lambda: self._send_keep_out(now))
        self.ctx.every(
            RECHECK_S,
            lambda now: self._zones.check(now, self.settings.value.zone_masks),
            name="zone-masks",
        )
        self.sender.remember("/page/info", self._send_page_info)
        listener = ViewerListener(
            asyncio.get_running_loop(), self._subscribed, self._on_command, self._unsubscribed
        )
        self._listener = listener
        try:
            self.server, self._gate = await serve_viewers(
                s.host,
                s.port,
                lambda: self.settings.value.viewers,
                self.ctx.log,
                name=f"navd {__version__} ({s.robot_name})",
                context=self.channels.context,
                server_listener=listener,
                capabilities=[Capability.ClientPublish],
                supported_encodings=["json"],
            )
        except Exception as err:  # a busy port or a bad address (OSError, the SDK: RuntimeError)
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
        add_log_tap(self._log_feed)
        self.ctx.every(lambda: self.settings.value.map_period_s, self._flush_map, name="viz-map")
        self.ctx.log.info("viz_listening", host=s.host, port=self._gate.port)
        if s.page_enabled:
            self._serve_page(s, self._gate.port)

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
            self.sender.remember("/footprint", lambda: self._send_footprint(now))
        if new.keep_out_zones != old.keep_out_zones:
            self.sender.remember("/keep_out", lambda: self._send_keep_out(now))
        self.sender.remember("/page/info", self._send_page_info)

    async def on_deactivate(self) -> None:
        remove_log_tap(self._log_feed)
        if self.page is not None:
            page, self.page = self.page, None
            await asyncio.to_thread(page.stop)  # waits up to a poll interval: off the loop
        if self.server is not None:
            self._gate.close()
            self.server.stop()
            self.server = None

    async def on_cleanup(self) -> None:
        self.channels.close()
        self.sender.forget()  # the last map and route are not held past the view's life
        self._map_pending = None
        self._page.forget()

    # --- viewers coming and going -----------------------------------------------------

    def _subscribed(self, topic: str) -> None:
        """Event loop: a viewer subscribed to ``topic``; it gets the latest state."""
        self._count(topic, +1)
        self.sender.replay(topic)

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

    def _on_state(self, state: RobotState) -> None:
        """The robot's state changed: the pose, the goal's progress or the status."""
        changed = state.changed
        if "pose" in changed and state.pose is not None:
            self._on_pose(state.pose)
        if "goal" in changed and state.goal is not None:
            message = goal_status_message(state.goal)
            channel = self.channels.goal_status
            self.sender.remember("/goal_status", lambda: self.sender.send(channel, message))
        if changed & STATUS_PARTS:
            self._send_status(state)

    def _send_status(self, state: RobotState) -> None:
        message, channel = status_message(state), self.channels.status
        self.sender.remember("/status", lambda: self.sender.send(channel, message))

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
        grid = functools.partial(scene.occupancy_grid, offset_s=self.sender.offset_s)
        submit = functools.partial(self.ctx.submit, "viz_map")
        self.sender.remember_built("/map", self.channels.map, grid, update, submit)
        self.sender.remember("/page/map", lambda: self._page.map(update))

    def _on_scan(self, scan: LaserScan) -> None:
        if self.server is None:
            return
        settings = self.settings.value
        period_s, lidar = settings.scan_period_s, scan.device_id
        mount = settings.mounts.lidar(lidar)
        throttle = self._scan_throttles.setdefault(lidar, Throttle())
        if self.sender.watched(self.channels.scan) and throttle.due(scan.received, period_s):
            shown = scene.laser_scan(scan, mount, offset_s=self.sender.offset_s)
            self.sender.send(self.channels.scan, shown)
        self._page.scan(scan, mount, period_s)

    def _on_pose(self, pose: PoseEstimate) -> None:
        channels, period_s = self.channels, self.settings.value.pose_period_s
        self._page.pose(pose, period_s)
        tf, odometry = self.sender.watched(channels.tf), self.sender.watched(channels.pose)
        in_frame = self.sender.watched(channels.pose_in_frame)
        if not (tf or odometry or in_frame) or not self._pose_throttle.due(pose.received, period_s):
            return
        offset_s = self.sender.offset_s
        if tf:
            lidar = self.settings.value.mounts.default_lidar.pose
            self.sender.send(channels.tf, scene.frame_tree(pose, lidar, offset_s=offset_s))
        if odometry:
            self.sender.send(channels.pose, scene.odometry(pose, offset_s=offset_s))
        if in_frame:
            self.sender.send(channels.pose_in_frame, scene.pose_in_frame(pose, offset_s=offset_s))

    def _on_path(self, path: Path) -> None:
        offset_s, channel = self.sender.offset_s, self.channels.route
        self.sender.remember(
            "/route",
            lambda: self.sender.send_built(
                channel, lambda p: scene.route_scene(p, offset_s=offset_s), path
            ),
        )
        self.sender.remember("/page/route", lambda: self._page.route(path))

    def _on_goal(self, goal: Goal) -> None:
        offset_s, channel = self.sender.offset_s, self.channels.goal
        self.sender.remember(
            "/goal",
            lambda: self.sender.send_built(
                channel, lambda g: scene.goal_scene(g, offset_s=offset_s), goal
            ),
        )
        self.sender.remember("/page/goal", lambda: self._page.goal(goal))

    def _on_costmap(self, update: CostmapUpdate) -> None:
        if self._costmap_throttle.due(update.stamp, self.settings.value.map_period_s):
            offset_s = self.sender.offset_s
            self.sender.remember(
                "/costmap",
                lambda: self.sender.send_built(
                    self.channels.costmap,
                    lambda u: scene.occupancy_grid(u, offset_s=offset_s),
                    update,
                ),
            )

    def _on_trajectory(self, trajectory: LocalTrajectory) -> None:
        if self._trajectory_throttle.due(trajectory.stamp, self.settings.value.pose_period_s):
            shown = scene.trajectory_scene(trajectory, offset_s=self.sender.offset_s)
            self.sender.send(self.channels.trajectory, shown)

    def _send_page_info(self) -> None:
        self._page.info(self.settings.value)

    def _send_footprint(self, now: float) -> None:
        footprint = self.settings.value.footprint
        shown = scene.footprint_scene(footprint, now + self.sender.offset_s)
        self.sender.send(self.channels.footprint, shown)

    def _send_keep_out(self, now: float) -> None:
        zones = self.settings.value.keep_out_zones
        shown = scene.keep_out_scene(zones, now + self.sender.offset_s)
        self.sender.send(self.channels.keep_out, shown)

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
