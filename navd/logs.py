"""Structured logging with structlog: JSON lines for journald, readable lines on a terminal.

Every module gets its logger with ``get_logger("component")``; details go in fields, never in
formatted strings.
"""

from __future__ import annotations

import logging
import sys
from typing import Any, Literal, TextIO, cast

import structlog
from structlog.typing import FilteringBoundLogger

__all__ = ["configure_logging", "get_logger", "set_level"]

_LEVELS = {
    "debug": logging.DEBUG,
    "info": logging.INFO,
    "warning": logging.WARNING,
    "error": logging.ERROR,
}
_state: dict[str, Any] = {"stream": sys.stderr, "renderer": "console"}


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
    out = stream if stream is not None else sys.stderr
    renderer = fmt
    if fmt == "auto":
        renderer = "console" if out.isatty() else "json"
    _state.update(stream=out, renderer=renderer)
    _apply(level)


def set_level(level: str) -> None:
    """Change the lowest level written, keeping the format and stream."""
    _apply(level)


def _apply(level: str) -> None:
    processors: list[Any] = [
        structlog.contextvars.merge_contextvars,
        structlog.processors.add_log_level,
        structlog.processors.TimeStamper(fmt="iso", utc=True),
        structlog.processors.StackInfoRenderer(),
    ]
    if _state["renderer"] == "json":
        processors += [
            structlog.processors.dict_tracebacks,
            structlog.processors.JSONRenderer(),
        ]
    else:
        processors.append(structlog.dev.ConsoleRenderer(colors=_state["stream"].isatty()))
    structlog.configure(
        processors=processors,
        wrapper_class=structlog.make_filtering_bound_logger(_LEVELS[level]),
        logger_factory=structlog.PrintLoggerFactory(file=_state["stream"]),
        cache_logger_on_first_use=False,
    )


def get_logger(component: str) -> FilteringBoundLogger:
    """A logger bound to ``component`` (the module or subsystem name)."""
    return cast(FilteringBoundLogger, structlog.get_logger().bind(component=component))
