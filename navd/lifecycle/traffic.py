"""Lines counted per device, in and out: what a simulator in lockstep synchronizes on.

The drivers count every line they take in from a device (a sensor frame, good or bad; a
chassis encoder line; the end of a connection counts as one more) and every line they write
to one (a chassis wheel command). A simulator that owns the clock says how many lines it
has sent each device before it lets time move on; the daemon waits until it has read that
many (``wait_received``), so a frame sent before a tick is always handled before the tick,
whatever the sockets' timing. The counts are cumulative over the daemon's life.
"""

from __future__ import annotations

import asyncio
from collections import Counter
from collections.abc import Mapping

__all__ = ["Traffic"]


class Traffic:
    """Counters of lines received from and sent to each device id. Event loop only."""

    def __init__(self) -> None:
        self.received: Counter[str] = Counter()
        self.sent: Counter[str] = Counter()
        self._waiter: asyncio.Future[None] | None = None

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
