"""Lines counted per device, in and out: what a simulator in lockstep synchronizes on.

The drivers count every line they take in from a device (a sensor frame, good or bad; a
chassis encoder line; the end of a connection counts as one more) and every line they write
to one (a chassis wheel command). A simulator that owns the clock says how many lines it
has sent each device before it lets time move on; the daemon waits until it has read that
many (``wait_received``), so a frame sent before a tick is always handled before the tick,
whatever the sockets' timing. The counts are cumulative over the daemon's life.

On simulated time (``defer``) what the drivers take in is also held until the step
(``take``), then handled in device-id order (``release``): lines of different devices that
came within one step are handled in the same order whichever socket the kernel delivered
first, so a simulation is the same run after run.
"""

from __future__ import annotations

import asyncio
import itertools
from collections import Counter
from collections.abc import Callable, Mapping

__all__ = ["LineCounts"]

MAX_HELD = 10_000  # batches held at most: with no clock client moving time, memory stays bounded


class LineCounts:
    """Counters of lines received from and sent to each device id. Event loop only.

    Args:
        defer: hold taken-in lines until ``release`` (simulated time); otherwise they are
            handled at once.
    """

    def __init__(self, *, defer: bool = False) -> None:
        self.defer = defer
        self.received: Counter[str] = Counter()
        self.sent: Counter[str] = Counter()
        self._waiter: asyncio.Future[None] | None = None
        self._held: list[tuple[str, int, Callable[[], None]]] = []
        self._order = itertools.count()

    def take(self, device_id: str, lines: int, handle: Callable[[], None]) -> None:
        """Count ``lines`` from ``device_id`` and handle them: now, or at ``release``."""
        if self.defer:
            if len(self._held) >= MAX_HELD:
                self.release()  # nobody is stepping the clock: handle rather than hoard
            self._held.append((device_id, next(self._order), handle))
            self.add_received(device_id, lines)
        else:
            self.add_received(device_id, lines)
            handle()

    def release(self) -> int:
        """Handle what was held, by device id, each device's lines in arrival order.

        Returns:
            how many batches were handled.
        """
        held, self._held = sorted(self._held, key=lambda h: (h[0], h[1])), []
        for _, _, handle in held:
            handle()
        return len(held)

    def add_received(self, device_id: str, lines: int = 1) -> None:
        """Count ``lines`` taken in from ``device_id``."""
        self.received[device_id] += lines
        if self._waiter is not None and not self._waiter.done():
            self._waiter.set_result(None)

    def add_sent(self, device_id: str, lines: int = 1) -> None:
        """Count ``lines`` written to ``device_id``."""
        self.sent[device_id] += lines

    def missing(self, expected: Mapping[str, int]) -> dict[str, int]:
        """Per device, how many of the ``expected`` received lines have not come yet."""
        return {
            device: count - self.received[device]
            for device, count in expected.items()
            if self.received[device] < count
        }

    async def wait_received(self, expected: Mapping[str, int], timeout_s: float) -> dict[str, int]:
        """Wait until ``expected[device]`` lines came from each device, or ``timeout_s`` [s]
        of real time passed.

        Returns:
            what is still missing (empty when everything came).
        """
        loop = asyncio.get_running_loop()
        deadline = loop.time() + timeout_s
        while missing := self.missing(expected):
            remaining = deadline - loop.time()
            if remaining <= 0.0:
                return missing
            self._waiter = loop.create_future()
            try:
                await asyncio.wait_for(self._waiter, remaining)
            except TimeoutError:
                return self.missing(expected)
            finally:
                self._waiter = None
        return {}
