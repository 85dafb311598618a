"""The live view's JSON channels carry real JSON schemas: a viewer connected to the real
view sees each advertised with its schema, every message it then gets on them is valid
against that schema (checked by the ``jsonschema`` library) and a message built wrong is
not; and each schema is one Foxglove and Lichtblick can read (by their parser's rule,
``viewer_schema_rule``), or they would drop the channel."""

from __future__ import annotations

import asyncio
import json
import math
from typing import Any

import jsonschema
import numpy as np

from navd.lifecycle.messages import (
    BatteryState,
    Goal,
    GoalStatus,
    LocalizationState,
    Path,
    PoseEstimate,
    RobotState,
    SafetyState,
)
from navd.viz import page_data, status_feed
from navd.viz.view_schemas import VIEW_SCHEMAS
from tests.viz.foxglove_client import FoxgloveClient
from tests.viz.test_node import map_update, scan, viewed_daemon
from tests.viz.viewer_schema_rule import unreadable


def _validator(schema: dict[str, Any]) -> jsonschema.Draft202012Validator:
    jsonschema.Draft202012Validator.check_schema(schema)
    return jsonschema.Draft202012Validator(schema)


async def test_every_json_channel_is_advertised_with_a_schema_its_messages_follow() -> None:
    topics = set(VIEW_SCHEMAS)
    async with viewed_daemon() as (daemon, node):
        assert node.port is not None
        client = await FoxgloveClient.open(node.port)
        try:
            await client.wait_for_topics(topics)
            validators = {}
            for topic in topics:
                channel = client.channels[topic]
                assert (channel.encoding, channel.schema_encoding) == ("json", "jsonschema")
                schema = json.loads(channel.schema)
                assert unreadable(schema) == [], topic  # as sent, a viewer can read it
                validators[topic] = _validator(schema)
            await client.subscribe(*topics)
            t = daemon.clock.now()
            stamps = {"stamp": t, "received": t}
            daemon.bus.publish(map_update(t))

            async def move() -> None:  # the pose and scans stream (the page's come throttled)
                while True:
                    now = daemon.clock.now()
                    covariance = np.diag([0.01, 0.01, 0.01])
                    at = {"stamp": now, "received": now, "yaw_rad": 0.1}
                    daemon.bus.publish(PoseEstimate(**at, x_m=0.5, y_m=0.2, covariance=covariance))
                    daemon.bus.publish(scan(now))
                    await asyncio.sleep(0.1)

            streaming = asyncio.create_task(move())
            daemon.bus.publish(SafetyState(**stamps, reasons=("lidar stale",)))
            daemon.bus.publish(
                LocalizationState(**stamps, state="ok", position_std_m=0.02, yaw_std_rad=0.01)
            )
            daemon.bus.publish(Goal(**stamps, goal_id="g", x_m=2.0, y_m=1.0))
            route = np.array([[0.5, 0.2], [1.2, 0.6], [2.0, 1.0]])
            daemon.bus.publish(Path(**stamps, goal_id="g", points_m=route))
            daemon.bus.publish(GoalStatus(**stamps, goal_id="g", state="active"))  # NaN ETA
            seen: set[str] = set()
            deadline = asyncio.get_running_loop().time() + 30.0
            try:
                while seen != topics:
                    left = deadline - asyncio.get_running_loop().time()
                    topic, _, message = await client.receive_any(timeout_s=max(left, 0.0))
                    validators[topic].validate(message)
                    seen.add(topic)
            except TimeoutError:
                raise AssertionError(f"nothing on {topics - seen}") from None
            finally:
                streaming.cancel()
        finally:
            await client.close()


def test_a_message_unlike_its_schema_is_refused() -> None:
    _, pose_schema = VIEW_SCHEMAS["/page/pose"]
    pose = {"stamp": 1.0, "x": 1.0, "y": 2.0, "yaw": 0.1, "std_xy": 0.02}
    pose |= {"linear": 0.2, "angular": 0.0}
    validator = _validator(pose_schema)
    assert validator.is_valid(pose)
    assert not validator.is_valid({k: v for k, v in pose.items() if k != "yaw"})
    assert not validator.is_valid({**pose, "x_m": 1.0})
    assert not validator.is_valid({**pose, "x": None})  # a pose has no unknown coordinate
    _, status_schema = VIEW_SCHEMAS["/status"]
    held = {"safety": {"stopped": True, "reasons": ["e-stop"]}}
    assert _validator(status_schema).is_valid(held)
    assert not _validator(status_schema).is_valid({"safety": {"stopped": "yes", "reasons": []}})


def test_every_schema_is_one_the_viewers_read() -> None:
    for topic, (_, schema) in VIEW_SCHEMAS.items():
        assert unreadable(schema) == [], topic


def test_the_viewers_rule_refuses_what_their_parser_cannot_read() -> None:
    def with_field(field: dict[str, Any]) -> dict[str, Any]:
        return {"type": "object", "properties": {"f": field}}

    assert unreadable(with_field({"type": ["number", "null"]}))
    assert unreadable(with_field({"anyOf": [{"type": "number"}, {"type": "null"}]}))
    assert unreadable(with_field({"type": "array", "items": {"type": "array"}}))
    assert unreadable(with_field({"type": "object", "additionalProperties": {}}))
    assert unreadable(with_field({"type": "string", "contentEncoding": "base16"}))
    assert unreadable(with_field({"type": "array", "items": {"type": "number"}})) == []


def test_what_is_not_known_is_left_out_not_null() -> None:
    t = 5.0
    stamps = {"stamp": t, "received": t}
    status = VIEW_SCHEMAS["/goal_status"][1]
    pending = GoalStatus(**stamps, goal_id="g", state="pending")  # no distance, no ETA yet
    message = status_feed.goal_status_message(pending)
    assert "eta_s" not in message and "distance_remaining_m" not in message
    _validator(status).validate(message)
    goal = page_data.goal_message(Goal(**stamps, goal_id="g", x_m=1.0, y_m=2.0))
    assert "yaw" not in goal
    _validator(VIEW_SCHEMAS["/page/goal"][1]).validate(goal)
    turned = page_data.goal_message(Goal(**stamps, goal_id="g", x_m=1.0, y_m=2.0, yaw_rad=0.5))
    assert turned["yaw"] == 0.5
    battery = BatteryState(**stamps, device_id="bms", voltage_v=12.1)  # no charge, no current
    lost = LocalizationState(**stamps, state="lost", position_std_m=math.nan, yaw_std_rad=0.3)
    state = RobotState(**stamps, changed=frozenset({"battery"}), battery=battery, localization=lost)
    shown = status_feed.status_message(state)
    assert shown["battery"] == {"voltage_v": 12.1, "alarm": "ok"}
    assert shown["localization"] == {"state": "lost", "yaw_std_rad": 0.3}
    _validator(VIEW_SCHEMAS["/status"][1]).validate(shown)
