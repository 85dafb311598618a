"""``navd demo`` takes Ctrl-C and SIGTERM as "end the drive" while it drives, and gives the
signals back to the handlers of before when the drive is over."""

from __future__ import annotations

import asyncio
import os
import signal
from types import FrameType

from navd.sim.demo import _ended_by_signals


def test_sigterm_ends_the_drive_then_goes_back_to_the_handler_of_before() -> None:
    taken: list[int] = []

    def before(signum: int, _frame: FrameType | None) -> None:
        taken.append(signum)

    async def drive() -> bool:
        with _ended_by_signals() as ended:
            os.kill(os.getpid(), signal.SIGTERM)
            await asyncio.wait_for(ended.wait(), 5.0)
            return ended.is_set()

    previous = signal.signal(signal.SIGTERM, before)
    try:
        assert asyncio.run(drive())
        assert taken == []  # during the drive the event took it
        assert signal.getsignal(signal.SIGTERM) is before
        os.kill(os.getpid(), signal.SIGTERM)  # after it (the picture being drawn): before's
        assert taken == [signal.SIGTERM]
    finally:
        signal.signal(signal.SIGTERM, previous)
