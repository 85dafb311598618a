"""How the live view sends: only to channels someone watches, stamped on the wall clock as
the view shows it, and remembering each topic's latest state for a viewer who subscribes
later (map, route, goal, outline, zones, status).

A subscription sends the topic's latest state to every viewer of it (the server has no
per-viewer send), so a storm of subscriptions (viewers subscribing and leaving every few
milliseconds) would rebuild and resend a large map each time: a topic's state is sent again
at most every ``REPLAY_GAP_S``, later subscribers in that gap served together."""

from __future__ import annotations

import asyncio
import math
import time
from collections.abc import Callable, Mapping
from typing import Any

from navd.lifecycle import Clock
from navd.viz import scene

__all__ = ["REPLAY_GAP_S", "Sender"]

REPLAY_GAP_S = 0.5  # [s] a topic's latest state goes again to new subscribers at most this often


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
        self._replayed: dict[str, float] = {}  # topic -> [s, monotonic] when last sent again
        self._replay_due: dict[str, asyncio.TimerHandle] = {}  # topic -> its coming replay

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

    def remember_built(
        self,
        topic: str,
        channel: Any,
        build: Callable[[Any], Any],
        source: Any,
        submit: Callable[[Callable[[], None]], None],
    ) -> None:
        """``remember`` for a state that is costly to build (the map): ``build(source)`` runs
        once, when first watched, in a worker (``submit``: building and logging a 2000² map
        took the loop ~10 ms), and each later send reuses it."""
        built: list[Any] = []

        def send() -> None:
            if not self.watched(channel):
                return
            log_time = self.log_time()

            def job() -> None:
                if not built:
                    built.append(build(source))
                channel.log(built[0], log_time=log_time)  # the SDK's channels take any thread

            submit(job)

        self.remember(topic, send)

    def replay(self, topic: str) -> None:
        """Send ``topic``'s latest state again (a viewer just subscribed to it): now, or
        when REPLAY_GAP_S has passed since it was last sent again (event loop only)."""
        if topic not in self._latest or topic in self._replay_due:
            return
        wait_s = self._replayed.get(topic, -math.inf) + REPLAY_GAP_S - time.monotonic()
        if wait_s <= 0.0:
            self._replay_now(topic)
        else:
            loop = asyncio.get_running_loop()
            self._replay_due[topic] = loop.call_later(wait_s, self._replay_now, topic)

    def _replay_now(self, topic: str) -> None:
        self._replay_due.pop(topic, None)
        self._replayed[topic] = time.monotonic()
        send = self._latest.get(topic)
        if send is not None:
            send()

    def forget(self) -> None:
        """Hold no state past the view's life."""
        self._latest.clear()
        for handle in self._replay_due.values():
            handle.cancel()
        self._replay_due.clear()
