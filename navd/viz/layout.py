"""The Foxglove layout for navd's live view, built with the SDK's layout classes.

One 3D panel (the map, scan, route, local trajectory, goal, keep-out zones and the robot's
outline, seen from above and following the robot; the costmap one click away) beside the
daemon's status, the goal's progress and the log. The repository keeps the JSON in
``config/foxglove/navd-live.json`` (``navd viz layout`` writes it again; a test keeps the two
equal) for Foxglove's "Import layout".

Lichtblick (and Foxglove Studio before the SDK's layouts) imports another format: the panels'
configs by id and a tree of two-way splits. ``lichtblick_layout`` turns the same layout into
it, with the robot's pose drawn from ``/pose/in_frame`` (Lichtblick's 3D panel does not draw
``foxglove.Odometry``); the repository keeps it in ``config/lichtblick/navd-live.json``.
"""

from __future__ import annotations

import json
from typing import Any

import foxglove.layouts as fl

__all__ = ["lichtblick_layout", "live_layout"]

# The SDK's panel types by the names Lichtblick's panels register (its log panel keeps the
# legacy name RosOut).
_LICHTBLICK_PANELS = {"ThreeDee": "3D", "RawMessages": "RawMessages", "Log": "RosOut"}


def live_layout() -> fl.Layout:
    """The layout: 3D view on the left, status, goal and log on the right."""
    view = fl.ThreeDeePanel(
        title="navd",
        config=fl.ThreeDeeConfig(
            follow_tf="base_link",
            fixed_frame="map",
            follow_mode="follow-position",
            scene=fl.BaseRendererSceneSettings(),
            topics={
                "/map": fl.BaseRendererGridTopicSettings(
                    visible=True,
                    color_mode="gradient",
                    color_field="occupancy",
                    gradient=("#f2f2f2ff", "#000000ff"),
                    min_value=0.0,
                    max_value=100.0,
                    draw_behind=True,
                ),
                "/scan": fl.BaseRendererLaserScanTopicSettings(
                    visible=True, point_size=3.0, color_mode="flat", flat_color="#ff3b30ff"
                ),
                "/pose": fl.BaseRendererPoseTopicSettings(
                    visible=True, type="arrow", show_covariance=True
                ),
                "/costmap": fl.BaseRendererGridTopicSettings(
                    visible=False,  # a click in the topic list shows it
                    color_mode="gradient",
                    color_field="occupancy",
                    gradient=("#00000000", "#ff00ffa0"),
                    min_value=0.0,
                    max_value=100.0,
                    draw_behind=True,
                ),
                "/route": fl.BaseRendererSceneUpdateTopicSettings(visible=True),
                "/trajectory": fl.BaseRendererSceneUpdateTopicSettings(visible=True),
                "/goal": fl.BaseRendererSceneUpdateTopicSettings(visible=True),
                "/footprint": fl.BaseRendererSceneUpdateTopicSettings(visible=True),
                "/keep_out": fl.BaseRendererSceneUpdateTopicSettings(visible=True),
            },
        ),
    )
    side = fl.SplitContainer(
        direction="column",
        items=[
            fl.SplitItem(
                proportion=2,
                content=fl.RawMessagesPanel(
                    title="status", config=fl.RawMessagesConfig(topic_path="/status")
                ),
            ),
            fl.SplitItem(
                proportion=1,
                content=fl.RawMessagesPanel(
                    title="goal", config=fl.RawMessagesConfig(topic_path="/goal_status")
                ),
            ),
            fl.SplitItem(
                proportion=2,
                content=fl.LogPanel(title="log", config=fl.LogConfig(topic_to_render="/log")),
            ),
        ],
    )
    return fl.Layout(
        content=fl.SplitContainer(
            direction="row",
            items=[
                fl.SplitItem(proportion=3, content=view),
                fl.SplitItem(proportion=1, content=side),
            ],
        )
    )


def lichtblick_layout() -> dict[str, Any]:
    """The live view's layout as Lichtblick's "Import from file" reads it."""
    configs: dict[str, Any] = {}
    root = _mosaic(json.loads(live_layout().to_json())["content"], configs)
    return {
        "configById": configs,
        "globalVariables": {},
        "userNodes": {},
        "playbackConfig": {"speed": 1.0},
        "layout": root,
    }


def _mosaic(node: dict[str, Any], configs: dict[str, Any]) -> Any:
    """A panel's id (its config put in ``configs``), or a two-way split of the items: the
    first against the rest, by their proportions."""
    if node["type"] == "panel":
        kind = _LICHTBLICK_PANELS[node["panelType"]]
        config = dict(node["config"])
        if kind == "3D":
            topics = dict(config["topics"])
            topics["/pose/in_frame"] = topics.pop("/pose")
            config["topics"] = topics
        elif kind == "RosOut":
            config = {"searchTerms": [], "minLogLevel": 1, **config}
        panel_id = f"{kind}!navd{len(configs) + 1}"
        configs[panel_id] = config
        return panel_id
    items = node["items"]
    if len(items) == 1:
        return _mosaic(items[0]["content"], configs)
    first = _mosaic(items[0]["content"], configs)
    rest = _mosaic({"type": "split", "direction": node["direction"], "items": items[1:]}, configs)
    share = items[0]["proportion"] / sum(item["proportion"] for item in items)
    return {
        "first": first,
        "second": rest,
        "direction": node["direction"],
        "splitPercentage": round(100.0 * share, 2),
    }
