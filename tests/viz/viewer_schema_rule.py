"""The rule by which Foxglove's and Lichtblick's 3D and plot panels read a JSON channel's
JSON schema, restated from the viewers' parser (Lichtblick's
``packages/mcap-support/src/parseJsonSchema.ts``, forked from Foxglove Studio's): a channel
whose schema breaks it is dropped by the viewer, so each schema navd sends must pass.

- the message and every nested object: ``"type": "object"`` with ``properties``;
- each property: one ``type`` of boolean, string, number, integer, object or array (no
  ``null``, no list of types, no ``anyOf``/``oneOf`` without a type);
- a string's ``contentEncoding``: none or base64;
- an array's ``items``: a boolean, number, integer, plain string or object, never an array.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

__all__ = ["unreadable"]

_SCALARS = ("boolean", "string", "number", "integer")


def unreadable(schema: Mapping[str, Any], where: str = "message") -> list[str]:
    """Why a viewer would drop a channel with ``schema``, a line per field; empty if none."""
    if schema.get("type") != "object":
        return [f"{where}: needs type object, has {schema.get('type')!r}"]
    properties = schema.get("properties")
    if not isinstance(properties, Mapping):
        return [f"{where}: an object without properties"]
    problems: list[str] = []
    for name, field in properties.items():
        path, kind = f"{where}.{name}", field.get("type")
        if kind == "object":
            problems += unreadable(field, path)
        elif kind == "array":
            items = field.get("items") or {}
            item_kind = items.get("type")
            if item_kind == "object":
                problems += unreadable(items, f"{path}[]")
            elif item_kind not in _SCALARS:
                problems.append(f"{path}: array items of type {item_kind!r}")
            elif item_kind == "string" and "contentEncoding" in items:
                problems.append(f"{path}: array items with a contentEncoding")
        elif kind not in _SCALARS:
            problems.append(f"{path}: type {kind!r}")
        elif kind == "string" and field.get("contentEncoding") not in (None, "base64"):
            problems.append(f"{path}: contentEncoding {field['contentEncoding']!r}")
    return problems
