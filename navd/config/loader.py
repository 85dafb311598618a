"""Reading, checking, changing and writing the TOML configuration.

Every failure is a ``ConfigError`` whose ``problems`` name the key path, the bad value and
what is expected. A runtime change goes through the same model as the file and is applied
whole or rejected whole.
"""

from __future__ import annotations

import difflib
import re
import textwrap
import tomllib
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import tomli_w
from pydantic import BaseModel, ValidationError

from navd.config.errors import ConfigError
from navd.config.fields import privileged, restart_required
from navd.config.model import NavdConfig
from navd.config.redaction import REDACTED, field_secret, model_at

__all__ = [
    "RESTART_ONLY",
    "RETIRED_KEYS",
    "apply_changes",
    "changed_keys",
    "check_runtime_changeable",
    "check_unprivileged",
    "dump_toml",
    "load_config",
    "parse_config",
]


# Keys that moved or went away: an older config file is told where to, not just "unknown".
RETIRED_KEYS = {
    "slam.laser_x_m": "moved to lidar.x_m",
    "slam.laser_y_m": "moved to lidar.y_m",
    "slam.laser_yaw_rad": "moved to lidar.yaw_rad",
    "slam.min_range_m": "moved to lidar.min_range_m",
    "logging.debug": 'removed (it changed nothing); set logging.level = "debug" for detail',
    "slam.match_resolution_m": "moved to `navd replay --fine-resolution` (only a replay refines "
    "its poses on a fine map; the daemon never did)",
}


def load_config(path: str | Path) -> NavdConfig:
    """Read and validate a TOML config file.

    Raises:
        ConfigError: the file is missing or unreadable, is not TOML, or has bad keys/values.
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError as err:
        raise ConfigError([f"{path}: config file does not exist"]) from err
    except IsADirectoryError as err:
        raise ConfigError([f"{path}: is a directory, not a config file"]) from err
    except (OSError, UnicodeDecodeError) as err:
        raise ConfigError([f"{path}: cannot be read: {err}"]) from err
    try:
        data = tomllib.loads(text)
        return parse_config(data, source=str(path))
    except tomllib.TOMLDecodeError as err:
        raise ConfigError([f"{path}: not valid TOML: {err}"]) from err
    except RecursionError as err:  # arrays nested thousands deep: no config looks like that
        raise ConfigError([f"{path}: nested too deeply to be a navd config"]) from err


def parse_config(data: Mapping[str, Any], source: str = "config") -> NavdConfig:
    """Validate a mapping (a parsed TOML document) into a NavdConfig.

    Raises:
        ConfigError: naming every bad key.
    """
    try:
        return NavdConfig.model_validate(dict(data))
    except ValidationError as err:
        raise ConfigError(_describe(err), source=source) from err


def apply_changes(
    config: NavdConfig, changes: Mapping[str, object], *, may_change_privileged: bool = True
) -> tuple[NavdConfig, tuple[str, ...]]:
    """Apply dotted-key changes (``{"safety.reaction_timeout_s": 0.3}``) to a config.

    A key may also name a whole section with a table of its keys as the value.

    Args:
        may_change_privileged: the changes may touch privileged keys (False for a control
            client the config does not grant it).

    Returns:
        The new config and the dotted keys whose value changed.

    Raises:
        ConfigError: an unknown key, a key that needs a restart, a privileged key without
            the right, or a value the model rejects; nothing is applied.
    """
    if not changes:
        raise ConfigError(["a config change must name at least one key"])
    problems: list[str] = []
    data = config.model_dump()
    for key, value in _flatten({str(k): v for k, v in changes.items()}).items():
        problems.extend(_set_dotted(data, key, value))
    if problems:
        raise ConfigError(problems, source="config change")
    new = parse_config(data, source="config change")
    changed = changed_keys(config, new)
    check_runtime_changeable(changed, source="config change")
    if not may_change_privileged:
        check_unprivileged(changed, source="config change")
    return new, changed


def check_runtime_changeable(changed: tuple[str, ...], source: str) -> None:
    """Raise if any of the dotted ``changed`` keys only takes effect at start-up.

    Raises:
        ConfigError: naming every such key.
    """
    blocked = [k for k in changed if _needs_restart(k)]
    if blocked:
        raise ConfigError(
            [f"{k}: cannot change while navd runs; edit the file and restart" for k in blocked],
            source=source,
        )


def check_unprivileged(changed: tuple[str, ...], source: str) -> None:
    """Raise if any of the dotted ``changed`` keys is privileged (a control client's change
    where the config does not grant it).

    Raises:
        ConfigError: naming every such key.
    """
    blocked = [k for k in changed if privileged(*k.split(".")[:2])]
    if blocked:
        raise ConfigError(
            [
                f"{k}: a privileged key (it can make the robot less safe or open it to "
                "others; docs/protocol.md lists the keys anyone may change); only the config "
                "file may change it unless tcp.allow_privileged_changes = true"
                for k in blocked
            ],
            source=source,
        )


def changed_keys(old: NavdConfig, new: NavdConfig) -> tuple[str, ...]:
    """The dotted keys whose value differs between two configs, in model order."""
    before, after = _flatten(old.model_dump()), _flatten(new.model_dump())
    return tuple(k for k in after if before.get(k) != after[k])


def dump_toml(config: NavdConfig, *, comments: bool = False) -> str:
    """Write a config back as TOML; with ``comments``, each key is preceded by its description.

    Unset optional keys are written as a commented-out example when ``comments`` is on, and
    left out otherwise (TOML has no null).
    """
    if not comments:
        return tomli_w.dumps(config.model_dump(exclude_none=True))
    lines = [
        "# navd configuration. Every key is listed with its default; units are in brackets.",
        "# Check a file with `navd config check FILE`; regenerate this one with",
        "# `navd config dump --comments > config/navd.toml`.",
    ]
    for section_name, section_field in NavdConfig.model_fields.items():
        section = getattr(config, section_name)
        assert isinstance(section, BaseModel)
        lines += ["", f"[{section_name}]"]
        if section_field.annotation is not None and section_field.annotation.__doc__:
            doc = " ".join(section_field.annotation.__doc__.split())
            header = lines.pop()
            lines += textwrap.wrap(doc, width=98, initial_indent="# ", subsequent_indent="# ")
            lines.append(header)
        for name, field in type(section).model_fields.items():
            note = field.description or ""
            if restart_required(type(section), name):
                note += " (needs a restart)"
            elif privileged(section_name, name):
                note += " (privileged: from the config file only, see tcp.allow_privileged_changes)"
            lines += textwrap.wrap(note, width=98, initial_indent="# ", subsequent_indent="# ")
            value = getattr(section, name)
            if isinstance(value, dict):  # a table of tables by name (the sensor mounts)
                lines += _named_tables(f"{section_name}.{name}", value, field.examples)
            elif value is None:
                example = field.examples[0] if field.examples else ""
                lines.append(f"# {tomli_w.dumps({name: example}).strip()}")
            else:
                lines.append(tomli_w.dumps({name: _plain(value)}).strip())
    return "\n".join(lines) + "\n"


def _named_tables(
    prefix: str, tables: dict[str, BaseModel], examples: list[Any] | None
) -> list[str]:
    """``[prefix.name]`` tables, or the first example commented out when there are none."""
    if not tables:
        example: dict[str, Any] = examples[0] if examples else {}
        return [
            f"# {line}".rstrip()
            for key, item in example.items()
            for line in [f"[{prefix}.{toml_key(key)}]", *tomli_w.dumps(item).strip().splitlines()]
        ]
    lines: list[str] = []
    for key, item in tables.items():
        lines.append(f"[{prefix}.{toml_key(key)}]")
        lines += tomli_w.dumps(item.model_dump(exclude_none=True)).strip().splitlines()
    return lines


def toml_key(key: str) -> str:
    """``key`` as TOML writes it in a dotted name: bare when it may be, quoted otherwise (a
    device id with ``.`` or ``:``)."""
    if re.fullmatch(r"[A-Za-z0-9_-]+", key):
        return key
    return '"' + key.replace("\\", "\\\\").replace('"', '\\"') + '"'


def _plain(value: Any) -> Any:
    if isinstance(value, tuple):
        return [_plain(item) for item in value]
    return value


def _set_dotted(data: dict[str, Any], key: str, value: object) -> list[str]:
    """Set ``data[a][b]`` for ``key == "a.b"``; returns problems instead of raising."""
    parts = key.split(".")
    node: dict[str, Any] = data
    model: type[BaseModel] = NavdConfig
    for depth, part in enumerate(parts):
        fields = model.model_fields
        if part not in fields:
            return [_unknown(".".join(parts[: depth + 1]), list(fields))]
        annotation = fields[part].annotation
        is_section = isinstance(annotation, type) and issubclass(annotation, BaseModel)
        if depth == len(parts) - 1:
            if is_section:
                return [f"{key}: is a section; give a table of its keys, got {value!r}"]
            node[part] = value
            return []
        if not is_section and restart_required(model, part):
            # a table of named tables (the sensor mounts): settable only in the file
            return [f"{key}: cannot change while navd runs; edit the file and restart"]
        if not is_section:
            return [f"{key}: {'.'.join(parts[: depth + 1])} is a value, not a section"]
        assert isinstance(annotation, type) and issubclass(annotation, BaseModel)
        node = node[part]
        model = annotation
    return []


def _restart_only_keys() -> frozenset[str]:
    keys = set()
    for section, field in NavdConfig.model_fields.items():
        model = field.annotation
        assert isinstance(model, type) and issubclass(model, BaseModel)
        keys |= {
            f"{section}.{name}" for name in model.model_fields if restart_required(model, name)
        }
    return frozenset(keys)


# Every key that takes effect only at start-up (ports, threads, the map to load, the broker,
# the serial device...): refused by name while navd runs, from any control client or a
# SIGHUP reload alike (its marks in the model, ``fields.restart``, are the source).
RESTART_ONLY: frozenset[str] = _restart_only_keys()


def _needs_restart(dotted: str) -> bool:
    """Whether ``dotted`` is, or lies inside (a named mount's key), a restart-only key."""
    section, _, name = dotted.partition(".")
    return f"{section}.{name.split('.')[0]}" in RESTART_ONLY


def _flatten(data: Mapping[str, Any], prefix: str = "") -> dict[str, Any]:
    flat: dict[str, Any] = {}
    for key, value in data.items():
        dotted = f"{prefix}{key}"
        if isinstance(value, Mapping):
            flat.update(_flatten(value, dotted + "."))
        else:
            flat[dotted] = value
    return flat


def _unknown(dotted: str, options: list[str]) -> str:
    """The problem with an unknown key: where it went, or the nearest real key."""
    if dotted in RETIRED_KEYS:
        return f"{dotted}: {RETIRED_KEYS[dotted]}"
    name = dotted.rpartition(".")[2]
    return f"{dotted}: unknown key{_did_you_mean(name, options)}"


def _did_you_mean(name: str, options: list[str]) -> str:
    close = difflib.get_close_matches(name, options, n=1, cutoff=0.6)
    return f" (did you mean {close[0]!r}?)" if close else ""


def _field_description(loc: tuple[int | str, ...]) -> str | None:
    """The description of the field at ``loc``, walking nested models (and the entries of a
    table of named tables)."""
    parent = model_at(loc[:-1]) if loc else None
    name = loc[-1] if loc else None
    if parent is not None and isinstance(name, str) and name in parent.model_fields:
        return parent.model_fields[name].description
    # a part of a field's value (an item of a list): the nearest field that has words
    for end in range(len(loc) - 1, 0, -1):
        parent = model_at(loc[: end - 1])
        name = loc[end - 1]
        if parent is not None and isinstance(name, str) and name in parent.model_fields:
            return parent.model_fields[name].description
    return None


def _describe(err: ValidationError) -> list[str]:
    problems: list[str] = []
    for error in err.errors():
        loc = tuple(error["loc"])
        key = ".".join(str(part) for part in loc) or "the config"
        kind = error["type"]
        if kind == "extra_forbidden":
            parent = model_at(loc[:-1])
            problems.append(_unknown(key, list(parent.model_fields) if parent else []))
            continue
        if kind in ("model_type", "model_attributes_type", "dict_type"):
            problems.append(f"{key}: must be a table ([{key}] section), got {error.get('input')!r}")
            continue
        message = str(error["msg"]).removeprefix("Value error, ")
        if kind == "value_error":
            problems.append(message)
            continue
        value = error.get("input")
        shown = "" if isinstance(value, Mapping) else f" = {value!r}"
        if field_secret(loc):
            shown = f" = {REDACTED}"
        description = _field_description(loc)
        expected = f" (expected {description})" if description else ""
        problems.append(f"{key}{shown}: {message}{expected}")
    return problems
