"""The live view's JSON channels carry real JSON schemas: a viewer connected to the real
view sees each advertised with its schema, and every message it then gets on them is valid
against that schema (checked by the ``jsonschema`` library); a message built wrong is not."""

from __future__ import annotations

import asyncio
import json
from typing import Any

import jsonschema
import numpy as np

from navd.lifecycle.messages import (
    Goal,
    GoalStatus,
    LocalizationState,
    Path,
    PoseEstimate,
    SafetyState,
)
from navd.viz.view_schemas import VIEW_SCHEMAS
from tests.viz.foxglove_client import FoxgloveClient
from tests.viz.test_node import map_update, scan, viewed_daemon


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
                validators[topic] = _validator(json.loads(channel.schema))
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
