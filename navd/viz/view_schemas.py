"""JSON schemas of the live view's JSON channels: ``/status``, ``/goal_status`` and the
operator page's ``/page/*`` (``status_feed`` and ``page_data`` build the messages).

A viewer (Foxglove, Lichtblick) then lists each channel's fields and their types, and a
client of any language can check what it reads. Numbers JSON cannot hold are null.
"""

from __future__ import annotations

import json
from typing import Any

from foxglove import Schema

__all__ = ["VIEW_SCHEMAS", "view_schema"]

_DIALECT = "https://json-schema.org/draft/2020-12/schema"
_NUMBER = {"type": "number"}
_MAYBE_NUMBER = {"type": ["number", "null"]}
_STRING = {"type": "string"}
_STRINGS = {"type": "array", "items": _STRING}
_XY = {"type": "array", "prefixItems": [_NUMBER, _NUMBER], "minItems": 2, "maxItems": 2}


def _object(description: str, required: dict[str, Any], **optional: Any) -> dict[str, Any]:
    """An object with these fields and no others."""
    return {
        "type": "object",
        "description": description,
        "properties": {**required, **optional},
        "required": list(required),
        "additionalProperties": False,
    }


_STATUS = _object(
    "What holds the robot, who drives, how well it is localized, the battery, the daemon.",
    {
        "safety": _object(
            "The safety gate: whether it stops the robot, and every reason.",
            {"stopped": {"type": "boolean"}, "reasons": _STRINGS},
        )
    },
    drive=_object("Who drives.", {"mode": _STRING, "operator": _STRING}),
    localization=_object(
        "How well the robot knows where it is ([m], [rad], 1 sigma).",
        {"state": _STRING, "position_std_m": _MAYBE_NUMBER, "yaw_std_rad": _MAYBE_NUMBER},
    ),
    battery=_object(
        "The battery ([V], [A], [%]).",
        {
            "voltage_v": _NUMBER,
            "current_a": _MAYBE_NUMBER,
            "percentage": _MAYBE_NUMBER,
            "charging": {"type": ["boolean", "null"]},
            "alarm": {"enum": ["ok", "low", "critical"]},
        },
    ),
    stamp=_NUMBER,
    uptime_s=_NUMBER,
    loop_lag_max_ms=_NUMBER,
    safe_stop_reasons=_STRINGS,
    modules={
        "type": "object",
        "additionalProperties": _object(
            "A module: its state, whether it faulted, its handlers' failures.",
            {"state": _STRING, "faulted": {"type": "boolean"}, "failures": {"type": "integer"}},
        ),
    },
)
_GOAL_STATUS = _object(
    "The goal's progress: its state, the distance [m] and time [s] left, why it ended.",
    {
        "stamp": _NUMBER,
        "goal_id": _STRING,
        "state": _STRING,
        "distance_remaining_m": _MAYBE_NUMBER,
        "eta_s": _MAYBE_NUMBER,
        "reason": _STRING,
    },
)
_PAGE_INFO = _object(
    "What the page needs once: the robot, its outline [m], keep-out zones, teleop's speeds.",
    {
        "robot": _STRING,
        "footprint": {
            "oneOf": [
                _object("A circle.", {"kind": {"const": "circle"}, "radius": _NUMBER}),
                _object(
                    "A rectangle.",
                    {"kind": {"const": "rectangle"}, "length": _NUMBER, "width": _NUMBER},
                ),
            ]
        },
        "keep_out": {"type": "array", "items": {"type": "array", "items": _XY}},
        "teleop": _object(
            "Top speeds [m/s], [rad/s].", {"max_linear": _NUMBER, "max_angular": _NUMBER}
        ),
        "commands": {"type": "boolean"},
        "teleop_enabled": {"type": "boolean"},
    },
)
_PAGE_MAP = _object(
    "The occupancy grid: int8 cells (-1 unknown, 0..100 occupied %), row 0 at the origin.",
    {
        "stamp": _NUMBER,
        "width": {"type": "integer", "minimum": 0},
        "height": {"type": "integer", "minimum": 0},
        "resolution": {"type": "number", "exclusiveMinimum": 0},
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
    {"stamp": _NUMBER, "lidar": _STRING, "points_cm": {"type": "string"}},
)
_PAGE_ROUTE = _object(
    "The global route's points in the map frame [m].",
    {"stamp": _NUMBER, "goal_id": _STRING, "points": {"type": "array", "items": _XY}},
)
_PAGE_GOAL = _object(
    "Where the goal is [m, rad]; yaw null: any heading.",
    {"goal_id": _STRING, "x": _NUMBER, "y": _NUMBER, "yaw": _MAYBE_NUMBER},
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
