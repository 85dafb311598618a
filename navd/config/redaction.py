"""Secrets never shown: the config as plain data, and config changes, with every secret's value
(the broker's password, the token) replaced by a marker, for logs, recordings and
``config_get``; and whether a field (by its path in the config) holds a secret."""

from __future__ import annotations

import typing
from collections.abc import Mapping
from typing import Any

from pydantic import BaseModel

from navd.config.fields import is_secret
from navd.config.model import NavdConfig

__all__ = ["REDACTED", "field_secret", "model_at", "redacted", "redacted_changes"]

REDACTED = "<redacted>"


def redacted(config: NavdConfig) -> dict[str, Any]:
    """The config as plain data for a log line: every secret set is replaced by a marker."""
    data = config.model_dump(mode="json")
    for section_name, section in data.items():
        model = NavdConfig.model_fields[section_name].annotation
        assert isinstance(model, type) and issubclass(model, BaseModel)
        for name, value in section.items():
            if value is not None and is_secret(model, name):
                section[name] = REDACTED
    return data


def redacted_changes(changes: Mapping[str, object]) -> dict[str, object]:
    """Dotted-key changes (as ``apply_changes`` takes them) with every secret's value
    replaced by a marker, for a log line or a recording."""

    def walk(prefix: tuple[str, ...], value: object) -> object:
        if isinstance(value, Mapping):
            return {k: walk((*prefix, str(k)), v) for k, v in value.items()}
        return REDACTED if field_secret(prefix) else value

    return {key: walk(tuple(key.split(".")), value) for key, value in changes.items()}


def field_secret(loc: tuple[int | str, ...]) -> bool:
    """True if ``loc`` names a secret field (its value is never echoed)."""
    parent = model_at(loc[:-1]) if loc else None
    name = loc[-1] if loc else None
    return (
        parent is not None
        and isinstance(name, str)
        and name in parent.model_fields
        and is_secret(parent, name)
    )


def model_at(loc: tuple[int | str, ...]) -> type[BaseModel] | None:
    """The model at ``loc`` in the config (a table of named tables, like the sensor mounts,
    is looked through: its key names an entry, not a field); None where there is none."""
    model: type[BaseModel] = NavdConfig
    parts = list(loc)
    while parts:
        part = parts.pop(0)
        if not isinstance(part, str) or part not in model.model_fields:
            return None
        annotation = model.model_fields[part].annotation
        if typing.get_origin(annotation) is dict:
            if not parts:
                return None  # the table of tables itself
            parts.pop(0)  # an entry's name (a device id)
            annotation = typing.get_args(annotation)[1]
        if not (isinstance(annotation, type) and issubclass(annotation, BaseModel)):
            return None
        model = annotation
    return model
