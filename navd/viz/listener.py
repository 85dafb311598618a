"""What the live view hears from its server's threads, and how often it sends.

``ViewerListener`` hands each viewer's subscription and command on to the event loop;
``Throttle`` keeps a stream at its rate.
"""

from __future__ import annotations

import asyncio
import math
import threading
from collections.abc import Callable

from foxglove.websocket import ChannelView, Client, ClientChannel, ServerListener

__all__ = ["JITTER_FRACTION", "MAX_PENDING_COMMANDS", "Throttle", "ViewerListener"]

# Viewer commands waiting for the event loop at most; more are dropped (a flooding viewer).
MAX_PENDING_COMMANDS = 64


# A message may come this share of a period early and still be sent: a 10 Hz stream with
# jitter, capped at 10 Hz, keeps its 10 Hz, while on average no stream beats its cap.
JITTER_FRACTION = 0.2


class Throttle:
    """At most one send per period [s] of the daemon clock on average: each send moves the
    next deadline a period on (the period is read at each ask, so a changed rate applies at
    once), and a message up to JITTER_FRACTION of a period early is on time."""

    def __init__(self) -> None:
        self._next = -math.inf

    def due(self, now: float, period_s: float) -> bool:
        if now < self._next - JITTER_FRACTION * period_s:
            return False
        self._next = max(self._next, now) + period_s
        return True


class ViewerListener(ServerListener):
    """Hears the server (in its threads) and hands on to the event loop: each subscription's
    topic to ``on_subscribe`` (and to ``on_unsubscribe`` when it ends, a viewer leaving
    included), each viewer's command with its topic to ``on_command``. At most
    MAX_PENDING_COMMANDS commands wait at once; a viewer flooding the server loses the rest
    (counted), never the loop's time."""

    def __init__(
        self,
        loop: asyncio.AbstractEventLoop,
        on_subscribe: Callable[[str], None],
        on_command: Callable[[int, str, bytes], None],
        on_unsubscribe: Callable[[str], None],
    ):
        self._loop = loop
        self._on_subscribe = on_subscribe
        self._on_unsubscribe = on_unsubscribe
        self._on_command = on_command
        self._topics: dict[tuple[int, int], str] = {}  # (client, its channel) -> topic
        self._lock = threading.Lock()
        self.pending = 0
        self.dropped = 0

    def on_subscribe(self, client: Client, channel: ChannelView) -> None:
        self._loop.call_soon_threadsafe(self._on_subscribe, channel.topic)

    def on_unsubscribe(self, client: Client, channel: ChannelView) -> None:
        self._loop.call_soon_threadsafe(self._on_unsubscribe, channel.topic)

    def on_client_advertise(self, client: Client, channel: ClientChannel) -> None:
        self._topics[(client.id, channel.id)] = channel.topic

    def on_client_unadvertise(self, client: Client, client_channel_id: int) -> None:
        self._topics.pop((client.id, client_channel_id), None)

    def on_message_data(self, client: Client, client_channel_id: int, data: bytes) -> None:
        topic = self._topics.get((client.id, client_channel_id), "")
        with self._lock:
            if self.pending >= MAX_PENDING_COMMANDS:
                self.dropped += 1
                return
            self.pending += 1
        self._loop.call_soon_threadsafe(self._command, client.id, topic, bytes(data))

    def _command(self, client_id: int, topic: str, data: bytes) -> None:
        with self._lock:
            self.pending -= 1
        self._on_command(client_id, topic, data)
