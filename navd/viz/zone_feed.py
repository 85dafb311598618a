"""The zone masks (docs/planning.md) on the live view: ``/zones/keep_out`` (100 where the
robot may not go) and ``/zones/speed`` (1..100 % of its top speed), read in a worker when
the config names other files or their files change."""

from __future__ import annotations

import functools
from collections.abc import Callable

from foxglove.channels import GridChannel

from navd.planning import ZoneMasks
from navd.viz import scene
from navd.viz.sender import Sender

__all__ = ["ZoneFeed"]


class ZoneFeed:
    """Shows what changed in the zone masks (the last reading stays for later viewers).

    Args:
        sender: the view's.
        keep_out, speed: the two channels.
        submit: runs a job in a worker.
    """

    def __init__(
        self,
        sender: Sender,
        keep_out: GridChannel,
        speed: GridChannel,
        submit: Callable[[Callable[[], None]], None],
    ) -> None:
        self._sender = sender
        self._keep_out = keep_out
        self._speed = speed
        self._submit = submit
        self._zones: ZoneMasks | None = None
        self._shown = -1  # the revision last shown

    def check(self, now: float, paths: tuple[str | None, str | None]) -> None:
        """Read the masks ``paths`` (keep-out, speed) name if they changed, and show them."""
        if self._zones is None and paths == (None, None):
            return

        def job() -> None:
            current = self._zones
            if current is None or current.paths != paths:
                current = self._zones = ZoneMasks(*paths)
            else:
                current.refresh(now)
            if current.revision == self._shown:
                return
            self._shown = current.revision
            for topic, channel, mask in (
                ("/zones/keep_out", self._keep_out, current.keep_out),
                ("/zones/speed", self._speed, current.speed),
            ):
                if mask is not None:
                    grid = scene.zone_grid(mask.frame, mask.values, now + self._sender.offset_s)
                    self._sender.remember(
                        topic, functools.partial(self._sender.send, channel, grid)
                    )

        self._submit(job)
