"""JSON schemas of navd's own JSON in a recording, one per message topic and one for the
session's header, so a viewer (Foxglove, Lichtblick) lists the fields for its panels and
plots and any reader can check a file without navd.

Each is built from the message's field types by ``record_codec``'s rules, in the part of
JSON Schema the viewers read (one type per field, no null, no arrays of arrays: a channel
whose schema they cannot read is dropped, see ``view_schemas``). So a schema names the
fields whose JSON has one such type: numbers (a value JSON cannot hold is left out and
listed in ``not_finite``), integers, strings, booleans, enums, arrays (``{"dtype", "shape",
"base64"}``) and lists of strings or integers. It leaves the others unnamed and allowed as
they are (optional values, which may be null; lists of numbers, which may hold "NaN"; fixed
tuples; nested models). ``/navd/config``'s is the config model's own, cut to that part the
same way: each section with its keys of one plain type (a key that may be unset, or of a
union of types, is left unnamed and allowed).
"""

from __future__ import annotations

import collections.abc
import dataclasses
import functools
import json
import typing
from enum import Enum
from typing import Any

import numpy as np

from navd.config import NavdConfig
from navd.lifecycle.messages import Message
from navd.viz.record_codec import CONFIG_TOPIC, NOT_FINITE, SESSION_TOPIC, kind_of

__all__ = ["SESSION_SCHEMA", "config_schema", "message_schema", "schema_bytes", "topic_schema"]

_DIALECT = "https://json-schema.org/draft/2020-12/schema"
_SIMPLE: dict[Any, dict[str, Any]] = {
    bool: {"type": "boolean"},
    int: {"type": "integer"},
    str: {"type": "string"},
}
_SPELLED = {"type": "string", "enum": ["NaN", "Infinity", "-Infinity"]}
_NOT_FINITE_LIST = {
    "type": "array",
    "description": "Number fields left out: their value, which JSON cannot hold.",
    "items": {
        "type": "object",
        "properties": {"field": {"type": "string"}, "value": _SPELLED},
        "required": ["field", "value"],
        "additionalProperties": False,
    },
}
_ARRAY = {
    "type": "object",
    "description": "An array: its numpy dtype, its shape, its bytes in base64.",
    "properties": {
        "dtype": {"type": "string"},
        "shape": {"type": "array", "items": {"type": "integer", "minimum": 0}},
        "base64": {"type": "string", "contentEncoding": "base64"},
    },
    "required": ["dtype", "shape", "base64"],
    "additionalProperties": False,
}

# The session's header, first in every file (``recorder``).
SESSION_SCHEMA: dict[str, Any] = {
    "$schema": _DIALECT,
    "title": "navd.Session",
    "description": "The recording session: when it began in the daemon's run, what it knew then.",
    "type": "object",
    "properties": {
        "began_s": {"type": "number", "description": "[s] daemon time when recording began"},
        "into_run_s": {"type": "number", "description": "[s] since the daemon started"},
        "had_map": {"type": "boolean", "description": "a map was known (recorded first)"},
        "seeded_pose": {"type": "boolean", "description": "a pose was known (recorded first)"},
        "session": {"type": "string", "description": "the session's name, in the file names"},
        "file_index": {"type": "integer", "minimum": 1, "description": "this file's number"},
    },
    "required": ["began_s", "into_run_s", "had_map", "seeded_pose", "session", "file_index"],
    "additionalProperties": False,
}


def topic_schema(topic: str) -> tuple[str, dict[str, Any]] | None:
    """The schema's name and the schema of what ``topic`` carries; None for a topic that is
    not navd's JSON."""
    if topic == SESSION_TOPIC:
        return "navd.Session", SESSION_SCHEMA
    if topic == CONFIG_TOPIC:
        return "navd.Config", config_schema()
    kind = kind_of(topic)
    if kind is None:
        return None
    return f"navd.{kind.__name__}", message_schema(kind)


@functools.cache
def config_schema() -> dict[str, Any]:
    """The config as recorded (its sections' keys; a secret redacted is still a string), in
    the part viewers read."""
    model = NavdConfig.model_json_schema(mode="serialization")
    definitions = model.get("$defs", {})
    shown = _plain_part(model, definitions)
    assert shown is not None  # the config is an object of sections
    return {"$schema": _DIALECT, "title": "navd.Config", **shown}


def _plain_part(schema: dict[str, Any], definitions: dict[str, Any]) -> dict[str, Any] | None:
    """``schema`` ($refs resolved) cut to what has one plain type: an object keeps the
    properties that do (the others are left unnamed, so still allowed), an array of them is
    kept; None when nothing is left of it."""
    ref = schema.get("$ref")
    if isinstance(ref, str):
        schema = {
            **definitions[ref.rsplit("/", 1)[-1]],
            **{k: v for k, v in schema.items() if k != "$ref"},
        }
    kind = schema.get("type")
    notes: dict[str, Any] = {k: schema[k] for k in ("description", "title") if k in schema}
    if kind == "object":
        properties = {}
        for name, field in (schema.get("properties") or {}).items():
            kept = _plain_part(field, definitions)
            if kept is not None:
                properties[name] = kept
        if not properties:
            return None
        required = [name for name in schema.get("required", []) if name in properties]
        return {"type": "object", **notes, "properties": properties, "required": required}
    if kind == "array":
        items = _plain_part(schema.get("items") or {}, definitions)
        if items is None or items.get("type") == "array":
            return None
        return {"type": "array", **notes, "items": items}
    if kind in ("boolean", "string", "number", "integer"):
        keep = ("minimum", "maximum", "exclusiveMinimum", "exclusiveMaximum", "enum")
        return {"type": kind, **notes, **{k: schema[k] for k in keep if k in schema}}
    return None


def message_schema(kind: type[Message]) -> dict[str, Any]:
    """The JSON schema of ``kind`` as ``record_codec.encode`` writes it (see the module
    docstring for the fields it names)."""
    hints = typing.get_type_hints(kind)
    properties: dict[str, Any] = {}
    required: list[str] = []
    for field in dataclasses.fields(kind):
        hint = hints[field.name]
        if hint is float:
            properties[field.name] = {"type": "number"}  # left out when not finite
            continue
        schema = _one_type(hint)
        if schema is not None:
            properties[field.name] = schema
            required.append(field.name)
    properties[NOT_FINITE] = _NOT_FINITE_LIST
    return {
        "$schema": _DIALECT,
        "title": f"navd.{kind.__name__}",
        "description": (kind.__doc__ or "").strip().split("\n\n")[0],
        "type": "object",
        "properties": properties,
        "required": required,
    }


def _one_type(hint: Any) -> dict[str, Any] | None:
    """The schema of a field whose JSON always has one type a viewer reads, or None."""
    if hint in _SIMPLE:
        return dict(_SIMPLE[hint])
    origin, args = typing.get_origin(hint), typing.get_args(hint)
    if origin is np.ndarray:
        return dict(_ARRAY)
    if isinstance(hint, type) and issubclass(hint, Enum):
        values = [member.value for member in hint]
        if all(isinstance(v, str) for v in values):
            return {"type": "string", "enum": values}
        return None
    sequence = origin in (list, collections.abc.Sequence) or (
        origin is tuple and len(args) == 2 and args[1] is Ellipsis
    )
    if sequence and args and args[0] in (str, int):  # never NaN inside
        return {"type": "array", "items": dict(_SIMPLE[args[0]])}
    return None


def schema_bytes(schema: dict[str, Any]) -> bytes:
    """A schema as a recording stores it."""
    return json.dumps(schema, separators=(",", ":")).encode()
