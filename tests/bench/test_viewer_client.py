"""The ingest benchmark's viewer subscribes to every channel and counts what comes."""

from __future__ import annotations

import asyncio

from navd.bench.ingest import _start_viewer, _stop_viewer
from tests.viz.test_node import scan, viewed_daemon


async def test_the_viewer_counts_every_channel_it_was_sent() -> None:
    async with viewed_daemon() as (daemon, node):
        assert node.port is not None
        viewer = await asyncio.to_thread(_start_viewer, node.port)
        try:
            await asyncio.sleep(0.5)  # its subscriptions reach the server
            for i in range(3):
                daemon.bus.publish(scan(daemon.clock.now() + i))
            await asyncio.sleep(0.5)
        finally:
            received = await asyncio.to_thread(_stop_viewer, viewer)
    assert received["/scan"] == 3
    assert received["/footprint"] == 1 and received["/keep_out"] == 1  # sent on subscribing
