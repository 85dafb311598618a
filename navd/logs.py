"""Structured logging with structlog: JSON lines for journald, readable lines on a terminal.

Every module gets its logger with ``get_logger("component")``; details go in fields, never in
formatted strings. Loggers follow the configuration in force when they write, so a level
changed at runtime (``set_level``) applies to every logger at once, including the ones
modules took at import. A tap (``add_log_tap``) sees every line written, as its fields: the
live view streams them.

Under systemd (``JOURNAL_STREAM`` set: the stream goes to the journal) each JSON line starts
with its syslog priority (``<4>`` for a warning), which journald takes as the line's
PRIORITY and strips, so ``journalctl -u navd -p warning`` shows navd's warnings and worse.
"""

from __future__ import annotations

import logging
import os
import sys
import threading
from collections.abc import Callable, Mapping
from typing import Any, Literal, TextIO, cast

import structlog
from structlog.typing import FilteringBoundLogger

__all__ = [
    "LogTap",
    "add_log_tap",
    "configure_logging",
    "current_level",
    "get_logger",
    "remove_log_tap",
    "set_level",
    "tap_failures",
]

LogTap = Callable[[Mapping[str, Any]], None]

_LEVELS = {
    "debug": logging.DEBUG,
    "info": logging.INFO,
    "warning": logging.WARNING,
    "error": logging.ERROR,
}
# stream None: standard error as it is when a line is written (tests swap it per test).
_state: dict[str, Any] = {"stream": None, "renderer": "console", "level": "info"}
_taps: list[LogTap] = []
_in_tap = threading.local()  # set while this thread runs the taps


def add_log_tap(tap: LogTap) -> None:
    """Call ``tap`` with the fields of every line written from now on (event, level,
    timestamp, component...), in the thread that writes it. A tap must be quick; what it
    raises is ignored (a log line is never lost to a tap)."""
    _taps.append(tap)


def remove_log_tap(tap: LogTap) -> None:
    """Stop calling ``tap`` (nothing if it was not added)."""
    if tap in _taps:
        _taps.remove(tap)


def _run_taps(_logger: Any, _method: str, event: dict[str, Any]) -> dict[str, Any]:
    if getattr(_in_tap, "active", False):
        return event  # a line a tap itself wrote: written, not tapped again (no loop)
    _in_tap.active = True
    try:
        for tap in tuple(_taps):
            try:
                tap(event)
            except Exception:  # a tap never costs the line itself; counted
                _state["tap_failures"] = _state.get("tap_failures", 0) + 1
    finally:
        _in_tap.active = False
    return event


# syslog priorities (RFC 5424) of the levels, for journald's line prefix
_PRIORITY = {"debug": 7, "info": 6, "warning": 4, "error": 3, "critical": 2}


class _JournalPrefix:
    """Puts the line's syslog priority in front of what ``render`` makes of it."""

    def __init__(self, render: Callable[[Any, str, Any], str]) -> None:
        self._render = render

    def __call__(self, logger: Any, method: str, event: Any) -> str:
        priority = _PRIORITY.get(str(event.get("level", "info")), 6)
        return f"<{priority}>{self._render(logger, method, event)}"


def tap_failures() -> int:
    """How many times a tap raised (the lines were written all the same)."""
    failures: int = _state.get("tap_failures", 0)
    return failures


def configure_logging(
    level: str = "info",
    fmt: Literal["auto", "json", "console"] = "auto",
    stream: TextIO | None = None,
) -> None:
    """Set up structlog for the whole process.

    Args:
        level: lowest level written ("debug", "info", "warning", "error").
        fmt: "json" for JSON lines, "console" for people, "auto" picks console on a TTY.
        stream: where logs go; standard error by default (journald keeps it).
    """
    renderer = fmt
    if fmt == "auto":
        renderer = "console" if (stream or sys.stderr).isatty() else "json"
    _state.update(stream=stream, renderer=renderer)
    _apply(level)


def set_level(level: str) -> None:
    """Change the lowest level written, keeping the format and stream."""
    _apply(level)


def current_level() -> str:
    """The lowest level written now."""
    level: str = _state["level"]
    return level


def _apply(level: str) -> None:
    _state["level"] = level
    processors: list[Any] = [
        structlog.contextvars.merge_contextvars,
        structlog.processors.add_log_level,
        structlog.processors.TimeStamper(fmt="iso", utc=True),
        structlog.processors.StackInfoRenderer(),
        _run_taps,
    ]
    if _state["renderer"] == "json":
        render: Any = structlog.processors.JSONRenderer()
        if os.environ.get("JOURNAL_STREAM"):
            render = _JournalPrefix(render)
        processors += [structlog.processors.dict_tracebacks, render]
    else:
        processors.append(structlog.dev.ConsoleRenderer(colors=_stream().isatty()))
    structlog.configure(
        processors=processors,
        wrapper_class=structlog.make_filtering_bound_logger(_LEVELS[level]),
        logger_factory=_print_logger,
        cache_logger_on_first_use=False,
    )


def _stream() -> TextIO:
    stream: TextIO = _state["stream"] or sys.stderr
    return stream


def _print_logger(*_args: Any) -> structlog.PrintLogger:
    return structlog.PrintLogger(_stream())


def get_logger(component: str) -> FilteringBoundLogger:
    """A logger bound to ``component`` (the module or subsystem name).

    It is assembled from the configuration in force at each call (about 2 us for a filtered
    debug line), never frozen at the level of the moment it was taken.
    """
    return cast(FilteringBoundLogger, structlog.get_logger(component=component))
