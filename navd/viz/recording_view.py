"""What a recording shows in Foxglove or Lichtblick: beside navd's own messages (JSON, for
replay and comparison), the map, each scan, the robot's pose and frame tree, the route and
the goal, on the live view's topics in Foxglove's schemas (``foxglove.Grid``, ``LaserScan``,
``FrameTransforms``, ``PoseInFrame``, ``SceneUpdate``): a recording opened in a viewer shows
the robot as the live view did. Built in the recorder's thread, never on the event loop."""

from __future__ import annotations

from foxglove import Context
from foxglove.channels import (
    FrameTransformsChannel,
    GridChannel,
    LaserScanChannel,
    PoseInFrameChannel,
    SceneUpdateChannel,
)

from navd.geometry import SensorMounts
from navd.lifecycle.messages import Goal, LaserScan, MapUpdate, Message, Path, PoseEstimate
from navd.viz import scene

__all__ = ["VIEW_TOPICS", "RecordingView"]

VIEW_TOPICS = ("/map", "/scan", "/tf", "/pose", "/route", "/goal")


class RecordingView:
    """The viewer's channels of one recording.

    Args:
        context: the recording's (its MCAP writer is a sink of it).
        mounts: where the lidars sit on the robot (each scan in its frame).
    """

    def __init__(self, context: Context, mounts: SensorMounts) -> None:
        self._mounts = mounts
        self.skipped = 0
        self._map = GridChannel("/map", context=context)
        self._scan = LaserScanChannel("/scan", context=context)
        self._tf = FrameTransformsChannel("/tf", context=context)
        self._pose = PoseInFrameChannel("/pose", context=context)
        self._route = SceneUpdateChannel("/route", context=context)
        self._goal = SceneUpdateChannel("/goal", context=context)

    def log(self, message: Message, log_time_ns: int) -> None:
        """Show ``message`` if a viewer draws it, stamped on the wall clock as recorded; one
        that cannot be (a time before 1970) is left out of the view, counted, never out of
        the recording."""
        try:
            self._log(message, log_time_ns)
        except (OverflowError, ValueError):
            self.skipped += 1

    def _log(self, message: Message, at: int) -> None:
        offset_s = at * 1e-9 - message.received  # the daemon's clock to the wall's
        if isinstance(message, LaserScan):
            mount = self._mounts.lidar(message.device_id)
            self._scan.log(scene.laser_scan(message, mount, offset_s=offset_s), log_time=at)
        elif isinstance(message, PoseEstimate):
            lidar = self._mounts.default_lidar.pose
            self._tf.log(scene.frame_tree(message, lidar, offset_s=offset_s), log_time=at)
            self._pose.log(scene.pose_in_frame(message, offset_s=offset_s), log_time=at)
        elif isinstance(message, MapUpdate):
            self._map.log(scene.occupancy_grid(message, offset_s=offset_s), log_time=at)
        elif isinstance(message, Path):
            self._route.log(scene.route_scene(message, offset_s=offset_s), log_time=at)
        elif isinstance(message, Goal):
            self._goal.log(scene.goal_scene(message, offset_s=offset_s), log_time=at)
