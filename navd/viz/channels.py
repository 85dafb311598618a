"""The live view's channels: one Foxglove channel per topic, all in one SDK context.

docs/liveview.md lists what each carries. The channels exist from the module's configure
on, so a message before the server starts finds its channel (and is sent to whoever
subscribes later).
"""

from __future__ import annotations

from typing import Any

from foxglove import Channel, Context
from foxglove.channels import (
    FrameTransformsChannel,
    GridChannel,
    LaserScanChannel,
    LogChannel,
    OdometryChannel,
    PoseInFrameChannel,
    SceneUpdateChannel,
)

from navd.viz.view_schemas import view_schema

__all__ = ["LiveChannels"]


def _json(topic: str, context: Context) -> Channel:
    """A JSON channel with its schema (``view_schemas``)."""
    return Channel(topic, schema=view_schema(topic), message_encoding="json", context=context)


class LiveChannels:
    """Every channel of the live view, in ``context``."""

    def __init__(self, context: Context) -> None:
        self.context = context
        self.map = GridChannel("/map", context=context)
        self.scan = LaserScanChannel("/scan", context=context)
        self.tf = FrameTransformsChannel("/tf", context=context)
        self.pose = OdometryChannel("/pose", context=context)
        # the pose again as a type Lichtblick's 3D panel draws (it does not draw Odometry)
        self.pose_in_frame = PoseInFrameChannel("/pose/in_frame", context=context)
        self.route = SceneUpdateChannel("/route", context=context)
        self.goal = SceneUpdateChannel("/goal", context=context)
        self.footprint = SceneUpdateChannel("/footprint", context=context)
        self.keep_out = SceneUpdateChannel("/keep_out", context=context)
        # the zone masks (docs/planning.md) as grids: keep-out 100, speed 1..100 % of top speed
        self.keep_out_mask = GridChannel("/zones/keep_out", context=context)
        self.speed_mask = GridChannel("/zones/speed", context=context)
        self.goal_status = _json("/goal_status", context)
        self.status = _json("/status", context)
        self.log = LogChannel("/log", context=context)
        # Made by the planner only while someone watches (see ViewInterest).
        self.costmap = GridChannel("/costmap", context=context)
        self.trajectory = SceneUpdateChannel("/trajectory", context=context)
        # The operator page's own channels (JSON: a phone decodes it natively).
        self.page_info = _json("/page/info", context)
        self.page_map = _json("/page/map", context)
        self.page_pose = _json("/page/pose", context)
        self.page_scan = _json("/page/scan", context)
        self.page_route = _json("/page/route", context)
        self.page_goal = _json("/page/goal", context)

    def all(self) -> tuple[Any, ...]:
        """Every channel."""
        return tuple(value for value in vars(self).values() if value is not self.context)

    def close(self) -> None:
        """Close every channel (the view is done)."""
        for channel in self.all():
            channel.close()
