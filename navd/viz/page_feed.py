"""The operator page's channels (JSON, small, for a phone): the robot's pose, the scan's hits
in the map frame, the map coarsened past a million cells (built in a worker, once per map),
the route, the goal and what the page shows of the robot (``page_data`` builds each)."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from navd.geometry import LidarMount
from navd.lifecycle.messages import Goal, LaserScan, MapUpdate, Path, PoseEstimate
from navd.viz import page_data
from navd.viz.channels import LiveChannels
from navd.viz.listener import Throttle
from navd.viz.sender import Sender
from navd.viz.settings import VizSettings

__all__ = ["PageFeed"]


class PageFeed:
    """Writes the page's channels.

    Args:
        sender: the view's.
        channels: the view's channels (the ``page_*`` ones are written).
        submit: runs a job in a worker.
    """

    def __init__(
        self,
        sender: Sender,
        channels: LiveChannels,
        submit: Callable[[Callable[[], None]], None],
    ) -> None:
        self._sender = sender
        self._channels = channels
        self._submit = submit
        self._pose: PoseEstimate | None = None  # the latest, to place the scan
        self._built_map: tuple[MapUpdate, dict[str, Any]] | None = None  # the last built
        self._scan_throttles: dict[str, Throttle] = {}  # by lidar
        self._pose_throttle = Throttle()

    def forget(self) -> None:
        """Hold nothing past the view's life."""
        self._pose = None
        self._built_map = None

    def info(self, settings: VizSettings) -> None:
        """What the page shows of the robot (its outline, teleop's top speeds)."""
        self._sender.send(self._channels.page_info, page_data.info_message(settings))

    def pose(self, pose: PoseEstimate, period_s: float) -> None:
        """The robot's pose, at most every ``period_s`` [s] (and the page's own limit)."""
        self._pose = pose
        channel = self._channels.page_pose
        if self._sender.watched(channel) and self._pose_throttle.due(
            pose.received, max(period_s, page_data.PAGE_POSE_PERIOD_S)
        ):
            self._sender.send(channel, page_data.pose_message(pose))

    def scan(self, scan: LaserScan, mount: LidarMount, period_s: float) -> None:
        """A scan's hits in the map frame (once a pose is known), at most every
        ``period_s`` [s] per lidar (and the page's own limit)."""
        pose, channel = self._pose, self._channels.page_scan
        throttle = self._scan_throttles.setdefault(scan.device_id, Throttle())
        if (
            pose is not None
            and self._sender.watched(channel)
            and throttle.due(scan.received, max(period_s, page_data.PAGE_SCAN_PERIOD_S))
        ):
            self._sender.send(channel, page_data.scan_message(scan, pose, mount))

    def map(self, update: MapUpdate) -> None:
        """The map, built in a worker (coarsening a large map takes tens of ms) once per map:
        a viewer subscribing later gets the same message."""
        channel = self._channels.page_map
        if not self._sender.watched(channel):
            return
        built = self._built_map
        if built is not None and built[0] is update:
            self._sender.send(channel, built[1])
            return
        log_time = self._sender.log_time()

        def job() -> None:
            message = page_data.map_message(update)
            self._built_map = (update, message)
            channel.log(message, log_time=log_time)  # the SDK's channels take any thread

        self._submit(job)

    def route(self, path: Path) -> None:
        """The route from the robot to the goal."""
        self._sender.send_built(self._channels.page_route, page_data.route_message, path)

    def goal(self, goal: Goal) -> None:
        """The goal."""
        self._sender.send_built(self._channels.page_goal, page_data.goal_message, goal)
