"""Changing a few keys of one table in a config file a person wrote, keeping the rest of it
(comments, order, spacing) as it is; the result is checked before it replaces the file."""

from __future__ import annotations

import contextlib
import os
import re
import tempfile
import tomllib
from pathlib import Path
from typing import Any

import tomli_w

from navd.config.errors import ConfigError
from navd.config.loader import parse_config

__all__ = ["set_table_keys"]

_HEADER = re.compile(r"^\s*\[\[?\s*([^\]]+?)\s*\]\]?\s*(#.*)?$")


def set_table_keys(path: Path, table: str, values: dict[str, Any]) -> None:
    """Set ``values`` in ``[table]`` of the TOML file at ``path`` (the table is added at the
    end when the file has none), then check the whole file and replace it atomically.

    Raises:
        ConfigError: the file cannot be read, or the changed file is not a valid config
            (the file is left as it was).
    """
    try:
        text = path.read_text() if path.exists() else ""
    except OSError as err:
        raise ConfigError([f"cannot read {path}: {err.strerror}"]) from err
    lines = text.splitlines()
    new = [f"{key} = {_inline(value)}" for key, value in values.items()]
    start = next(
        (i for i, line in enumerate(lines) if (m := _HEADER.match(line)) and m.group(1) == table),
        None,
    )
    if start is None:
        lines += ["", f"[{table}]", *new]
    else:
        end = next((i for i in range(start + 1, len(lines)) if _HEADER.match(lines[i])), len(lines))
        lines[start + 1 : end] = [*new, *_without_keys(lines[start + 1 : end], values)]
    changed = "\n".join(lines).lstrip("\n") + "\n"
    try:
        parse_config(tomllib.loads(changed), source=str(path))  # the whole file stays valid
    except tomllib.TOMLDecodeError as err:
        raise ConfigError([f"{path}: the change would not be valid TOML: {err}"]) from err
    folder = path.parent if str(path.parent) else Path(".")
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", dir=folder)
    try:
        with os.fdopen(fd, "w") as out:
            out.write(changed)
            out.flush()
            os.fsync(out.fileno())
        if path.exists():  # the file keeps its mode and, where allowed, its owner and group
            was = path.stat()
            os.chmod(tmp, was.st_mode & 0o777)
            with contextlib.suppress(PermissionError):
                os.chown(tmp, was.st_uid, was.st_gid)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def _inline(value: Any) -> str:
    """A value on one line (arrays inline, however nested)."""
    if isinstance(value, list | tuple):
        return "[" + ", ".join(_inline(item) for item in value) + "]"
    return tomli_w.dumps({"v": value}).strip()[len("v = ") :]


def _without_keys(lines: list[str], keys: dict[str, Any]) -> list[str]:
    """The table's lines without those of ``keys``, multi-line arrays included."""
    kept: list[str] = []
    depth = 0  # open brackets of a value being dropped
    for line in lines:
        if depth > 0:
            depth += line.count("[") - line.count("]")
            continue
        if "=" in line and line.split("=", 1)[0].strip() in keys:
            value = line.split("=", 1)[1].split("#", 1)[0]
            depth = value.count("[") - value.count("]")
            continue
        kept.append(line)
    return kept
