"""JSON schemas of navd's own JSON in a recording, one per topic.

Each recorded message is written as ``record_codec`` says (numbers, strings, lists, arrays as
``{"dtype", "shape", "base64"}``, NaN and infinity as strings); its schema is built from the
message's field types by the same rules, so a viewer (Foxglove, Lichtblick) lists the
fields and their types, and any reader can check a file without navd. The config's schema is
the config model's own (``NavdConfig``).
"""

from __future__ import annotations

import collections.abc
import dataclasses
import functools
import json
import types
import typing
from enum import Enum
from typing import Any

import numpy as np
from pydantic import BaseModel

from navd.config import REDACTED, NavdConfig
from navd.lifecycle.messages import Message
from navd.viz.record_codec import CONFIG_TOPIC, SESSION_TOPIC, kind_of

__all__ = [
    "DIALECT",
    "SESSION_SCHEMA",
    "config_schema",
    "message_schema",
    "schema_bytes",
    "topic_schema",
]

DIALECT = "https://json-schema.org/draft/2020-12/schema"
# What a number field holds: a JSON number, or one JSON cannot hold, spelled out.
_NUMBER = {"anyOf": [{"type": "number"}, {"enum": ["NaN", "Infinity", "-Infinity"]}]}

# The session's header, first in every file (``recorder``).
SESSION_SCHEMA: dict[str, Any] = {
    "$schema": DIALECT,
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
    """The config as recorded: the model's dump, a secret that was set replaced by
    ``REDACTED``."""
    schema = NavdConfig.model_json_schema(mode="serialization")
    for section in schema.get("$defs", {}).values():
        for name, field in section.get("properties", {}).items():
            if field.get("secret"):
                section["properties"][name] = {"anyOf": [field, {"const": REDACTED}]}
    return {"$schema": DIALECT, "title": "navd.Config", **schema}


def message_schema(kind: type[Message]) -> dict[str, Any]:
    """The JSON schema of ``kind`` as ``record_codec.encode`` writes it.

    Raises:
        TypeError: a field of a type the codec does not write (a programming error).
    """
    definitions: dict[str, Any] = {}
    hints = typing.get_type_hints(kind)
    names = [f.name for f in dataclasses.fields(kind)]
    schema: dict[str, Any] = {
        "$schema": DIALECT,
        "title": f"navd.{kind.__name__}",
        "description": (kind.__doc__ or "").strip().split("\n\n")[0],
        "type": "object",
        "properties": {name: _schema(hints[name], definitions) for name in names},
        "required": names,
        "additionalProperties": False,
    }
    if definitions:
        schema["$defs"] = definitions
    return schema


def _schema(hint: Any, definitions: dict[str, Any]) -> dict[str, Any]:
    """The schema of one field's value; a model's own definitions go to ``definitions``."""
    origin, args = typing.get_origin(hint), typing.get_args(hint)
    if hint is Any or hint is object:
        return {}
    if origin in (typing.Union, types.UnionType):
        return {"anyOf": [_schema(arg, definitions) for arg in args]}
    if hint is type(None):
        return {"type": "null"}
    simple = {bool: {"type": "boolean"}, int: {"type": "integer"}, str: {"type": "string"}}
    if hint in simple:
        return simple[hint]
    if hint is float:
        return _NUMBER
    if origin is np.ndarray:
        return _array(args)
    if origin in (tuple, list, collections.abc.Sequence):
        if origin is tuple and not (len(args) == 2 and args[1] is Ellipsis):
            items = [_schema(arg, definitions) for arg in args]
            return _fixed(items)
        return {"type": "array", "items": _schema(args[0], definitions)}
    if origin in (dict, collections.abc.Mapping):
        return {"type": "object", "additionalProperties": _schema(args[1], definitions)}
    if isinstance(hint, type):
        return _class(hint, definitions)
    raise TypeError(f"a recorded field of type {hint!r} has no JSON schema: add its rule")


def _class(hint: type, definitions: dict[str, Any]) -> dict[str, Any]:
    if issubclass(hint, Enum):
        return {"enum": [member.value for member in hint]}
    if issubclass(hint, BaseModel):
        model = hint.model_json_schema(mode="serialization", ref_template="#/$defs/{model}")
        definitions.update(model.pop("$defs", {}))
        return dict(model)
    if issubclass(hint, tuple) and hasattr(hint, "_fields"):  # a NamedTuple, written as a list
        hints = typing.get_type_hints(hint)
        return _fixed([_schema(hints[name], definitions) for name in hint._fields])
    raise TypeError(f"a recorded field of type {hint!r} has no JSON schema: add its rule")


def _fixed(items: list[dict[str, Any]]) -> dict[str, Any]:
    """A list of exactly these items."""
    count = len(items)
    return {"type": "array", "prefixItems": items, "minItems": count, "maxItems": count}


def _array(args: tuple[Any, ...]) -> dict[str, Any]:
    """An array as the codec writes it: its dtype, shape and bytes (base64)."""
    scalar = typing.get_args(args[1])[0] if len(args) == 2 else None
    dtype: dict[str, Any] = {"type": "string"}
    if isinstance(scalar, type) and issubclass(scalar, np.generic):
        dtype = {"const": np.dtype(scalar).str}
    return {
        "type": "object",
        "properties": {
            "dtype": dtype,
            "shape": {"type": "array", "items": {"type": "integer", "minimum": 0}},
            "base64": {"type": "string", "contentEncoding": "base64"},
        },
        "required": ["dtype", "shape", "base64"],
        "additionalProperties": False,
    }


def schema_bytes(schema: dict[str, Any]) -> bytes:
    """A schema as a recording stores it."""
    return json.dumps(schema, separators=(",", ":")).encode()
