"""The Foxglove layout for navd's live view, built with the SDK's layout classes.

One 3D panel (the map, scan, route, local trajectory, goal, keep-out zones and the robot's
outline, seen from above and following the robot; the costmap one click away) beside the
daemon's status, the goal's progress and the log. The repository keeps the JSON in
``config/foxglove/navd-live.json`` (``navd viz layout`` writes it again; a test keeps the two
equal) for Foxglove's or Lichtblick's "Import layout".
"""

from __future__ import annotations

import foxglove.layouts as fl

__all__ = ["live_layout"]


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
