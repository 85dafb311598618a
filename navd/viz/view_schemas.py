"""JSON schemas of the live view's JSON channels: ``/status``, ``/goal_status`` and the
operator page's ``/page/*`` (``status_feed`` and ``page_data`` build the messages).

A viewer (Foxglove, Lichtblick) lists each channel's fields and their types for its panels
and plots, and a client of any language can check what it reads. The viewers read a small
part of JSON Schema, and drop a channel whose schema they cannot read, so every schema
here keeps to it (tests/viz/viewer_schema_rule.py checks each by the viewers' rule):

- every object has a ``type`` of ``object`` and its ``properties``;
- every field has exactly one ``type`` (no ``null``, no list of types, no ``anyOf``);
- an array's items are numbers, strings, booleans or objects, never arrays.

So the messages are shaped to fit: a number that is not known is left out (never null), a
point is an object ``{x, y}``, a list of polygons a list of ``{points}``.
"""

from __future__ import annotations

import json
from typing import Any

from foxglove import Schema

__all__ = ["VIEW_SCHEMAS", "view_schema"]

_DIALECT = "https://json-schema.org/draft/2020-12/schema"
_NUMBER = {"type": "number"}
_STRING = {"type": "string"}
_BOOLEAN = {"type": "boolean"}
_STRINGS = {"type": "array", "items": _STRING}


def _object(description: str, required: dict[str, Any], **optional: Any) -> dict[str, Any]:
    """An object with these fields (the ``optional`` ones may be absent) and no others."""
    return {
        "type": "object",
        "description": description,
        "properties": {**required, **optional},
        "required": list(required),
        "additionalProperties": False,
    }


_XY = _object("A point [m] in the map frame.", {"x": _NUMBER, "y": _NUMBER})

_STATUS = _object(
    "What holds the robot, who drives, how well it is localized, the battery, the daemon.",
    {
        "safety": _object(
            "The safety gate: whether it stops the robot, and every reason.",
            {"stopped": _BOOLEAN, "reasons": _STRINGS},
        )
    },
    drive=_object("Who drives.", {"mode": _STRING, "operator": _STRING}),
    localization=_object(
        "How well the robot knows where it is (1 sigma; a spread not known is left out).",
        {"state": _STRING},
        position_std_m={**_NUMBER, "description": "[m]"},
        yaw_std_rad={**_NUMBER, "description": "[rad]"},
    ),
    battery=_object(
        "The battery; what it does not report is left out.",
        {
            "voltage_v": {**_NUMBER, "description": "[V]"},
            "alarm": {"type": "string", "enum": ["ok", "low", "critical"]},
        },
        current_a={**_NUMBER, "description": "[A], positive charging"},
        percentage={**_NUMBER, "description": "charge, 0..1"},
        charging=_BOOLEAN,
    ),
    stamp={**_NUMBER, "description": "[s] daemon time of the health report"},
    uptime_s=_NUMBER,
    loop_lag_max_ms=_NUMBER,
    safe_stop_reasons=_STRINGS,
    modules={
        "type": "array",
        "description": "Each module: its state, whether it faulted, its handlers' failures.",
        "items": _object(
            "A module.",
            {
                "name": _STRING,
                "state": _STRING,
                "faulted": _BOOLEAN,
                "failures": {"type": "integer", "minimum": 0},
            },
        ),
    },
)
_GOAL_STATUS = _object(
    "The goal's progress: its state, the distance and time left (left out when not known), "
    "why it ended.",
    {"stamp": _NUMBER, "goal_id": _STRING, "state": _STRING, "reason": _STRING},
    distance_remaining_m={**_NUMBER, "description": "[m]"},
    eta_s={**_NUMBER, "description": "[s]"},
)
_PAGE_INFO = _object(
    "What the page needs once: the robot, its outline [m], keep-out zones, teleop's speeds.",
    {
        "robot": _STRING,
        "footprint": _object(
            "The robot's outline: a circle (radius) or a rectangle (length, width) [m].",
            {"kind": {"type": "string", "enum": ["circle", "rectangle"]}},
            radius=_NUMBER,
            length=_NUMBER,
            width=_NUMBER,
        ),
        "keep_out": {
            "type": "array",
            "items": _object("A keep-out polygon.", {"points": {"type": "array", "items": _XY}}),
        },
        "teleop": _object(
            "Top speeds [m/s], [rad/s].", {"max_linear": _NUMBER, "max_angular": _NUMBER}
        ),
        "commands": _BOOLEAN,
        "teleop_enabled": _BOOLEAN,
    },
)
_PAGE_MAP = _object(
    "The occupancy grid: int8 cells (-1 unknown, 0..100 occupied %), row 0 at the origin.",
    {
        "stamp": _NUMBER,
        "width": {"type": "integer", "minimum": 0},
        "height": {"type": "integer", "minimum": 0},
        "resolution": {"type": "number", "exclusiveMinimum": 0, "description": "[m]"},
        "origin": _XY,
        "cells": {"type": "string", "contentEncoding": "base64"},
    },
)
_PAGE_POSE = _object(
    "The fused pose in the map frame [m, rad], its 1-sigma error [m] and its speeds.",
    {
        "stamp": _NUMBER,
        "x": _NUMBER,
        "y": _NUMBER,
        "yaw": _NUMBER,
        "std_xy": _NUMBER,
        "linear": _NUMBER,
        "angular": _NUMBER,
    },
)
_PAGE_SCAN = _object(
    "The latest scan's hits in the map frame: little-endian int32 x, y pairs [cm], base64.",
    {"stamp": _NUMBER, "lidar": _STRING, "points_cm": _STRING},
)
_PAGE_ROUTE = _object(
    "The global route's points in the map frame [m].",
    {"stamp": _NUMBER, "goal_id": _STRING, "points": {"type": "array", "items": _XY}},
)
_PAGE_GOAL = _object(
    "Where the goal is [m]; its heading [rad] left out when any heading will do.",
    {"goal_id": _STRING, "x": _NUMBER, "y": _NUMBER},
    yaw=_NUMBER,
)

# topic -> (schema name, schema)
VIEW_SCHEMAS: dict[str, tuple[str, dict[str, Any]]] = {
    topic: (name, {"$schema": _DIALECT, "title": name, **body})
    for topic, name, body in (
        ("/status", "navd.Status", _STATUS),
        ("/goal_status", "navd.GoalStatus", _GOAL_STATUS),
        ("/page/info", "navd.page.Info", _PAGE_INFO),
        ("/page/map", "navd.page.Map", _PAGE_MAP),
        ("/page/pose", "navd.page.Pose", _PAGE_POSE),
        ("/page/scan", "navd.page.Scan", _PAGE_SCAN),
        ("/page/route", "navd.page.Route", _PAGE_ROUTE),
        ("/page/goal", "navd.page.Goal", _PAGE_GOAL),
    )
}


def view_schema(topic: str) -> Schema:
    """The live view's schema of ``topic`` (one of ``VIEW_SCHEMAS``)."""
    name, body = VIEW_SCHEMAS[topic]
    return Schema(name=name, encoding="jsonschema", data=json.dumps(body).encode())
