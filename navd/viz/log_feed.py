"""Log lines as the live view's ``/log`` (foxglove.Log): those at or above
``viz.log_level``, with their fields, from whichever thread logs them."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

from foxglove.channels import LogChannel
from foxglove.messages import Log, LogLevel

from navd.viz import scene

__all__ = ["LogFeed"]

_LOG_LEVELS = {
    "debug": LogLevel.Debug,
    "info": LogLevel.Info,
    "warning": LogLevel.Warning,
    "error": LogLevel.Error,
    "critical": LogLevel.Fatal,
}
_RANK = {"debug": 0, "info": 1, "warning": 2, "error": 3, "critical": 4}
# Fields of a log line that are not its details.
_LOG_META = frozenset({"event", "level", "timestamp", "component"})


class LogFeed:
    """A log tap that writes each line to ``channel``.

    Args:
        channel: /log.
        lowest: the lowest level shown now (read at every line: a changed setting applies
            at once).
        wall_s: [s] now on the wall clock, as the view shows it.
    """

    def __init__(
        self, channel: LogChannel, lowest: Callable[[], str], wall_s: Callable[[], float]
    ) -> None:
        self._channel = channel
        self._lowest = lowest
        self._wall_s = wall_s

    def __call__(self, event: Mapping[str, Any]) -> None:
        """One log line (any thread)."""
        if not self._channel.has_sinks():
            return
        level = str(event.get("level", "info"))
        if _RANK.get(level, 1) < _RANK[self._lowest()]:
            return
        details = " ".join(f"{k}={v}" for k, v in event.items() if k not in _LOG_META)
        text = str(event.get("event", ""))
        wall_s = self._wall_s()
        self._channel.log(
            Log(
                timestamp=scene.as_timestamp(wall_s),
                level=_LOG_LEVELS.get(level, LogLevel.Unknown),
                message=f"{text} {details}" if details else text,
                name=str(event.get("component", "navd")),
            ),
            log_time=scene.nanoseconds(wall_s),
        )
