"""How the live view sends: only to channels someone watches, stamped on the wall clock as
the view shows it, and remembering each topic's latest state for a viewer who subscribes
later (map, route, goal, outline, zones, status)."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

from navd.lifecycle import Clock
from navd.viz import scene

__all__ = ["Sender"]


class Sender:
    """Sends to the view's channels.

    Args:
        clock: the daemon's clock.
        serving: whether the server runs (nothing is sent before it does, or after).
    """

    def __init__(self, clock: Clock, serving: Callable[[], bool]) -> None:
        self._clock = clock
        self._serving = serving
        self.offset_s = 0.0  # [s] wall clock minus daemon clock, fixed when the view starts
        self._latest: dict[str, Callable[[], None]] = {}  # topic -> send its latest state

    def log_time(self) -> int:
        """[ns] now, on the wall clock as the view shows it."""
        return scene.nanoseconds(self._clock.now() + self.offset_s)

    def watched(self, channel: Any) -> bool:
        """Whether anyone would receive what goes on ``channel`` now."""
        return self._serving() and bool(channel.has_sinks())

    def send(self, channel: Any, message: Any) -> None:
        """``message`` on ``channel`` if anyone watches (a JSON channel takes a mapping)."""
        if self.watched(channel):
            shown = dict(message) if isinstance(message, Mapping) else message
            channel.log(shown, log_time=self.log_time())

    def send_built(self, channel: Any, build: Callable[[Any], Any], source: Any) -> None:
        """``build(source)`` on ``channel``, built only when someone watches it."""
        if self.watched(channel):
            self.send(channel, build(source))

    def remember(self, topic: str, send: Callable[[], None]) -> None:
        """Keep how to send ``topic``'s latest state, and send it now if anyone watches."""
        self._latest[topic] = send
        send()

    def replay(self, topic: str) -> None:
        """Send ``topic``'s latest state again (a viewer just subscribed to it)."""
        send = self._latest.get(topic)
        if send is not None:
            send()

    def forget(self) -> None:
        """Hold no state past the view's life."""
        self._latest.clear()
