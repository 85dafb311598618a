from __future__ import annotations

import asyncio

from navd.lifecycle.traffic import Traffic


async def test_wait_received_returns_when_every_named_count_is_reached() -> None:
    traffic = Traffic()
    traffic.add_received("imu", 3)

    async def arrive() -> None:
        for _ in range(4):
            await asyncio.sleep(0.01)
            traffic.add_received("lidar")

    feeder = asyncio.create_task(arrive())
    missing = await traffic.wait_received({"imu": 3, "lidar": 4}, timeout_s=5.0)
    await feeder
    assert missing == {}
    assert traffic.received["lidar"] == 4


async def test_wait_received_reports_what_did_not_come_within_the_timeout() -> None:
    traffic = Traffic()
    traffic.add_received("lidar", 2)
    loop = asyncio.get_running_loop()
    started = loop.time()
    missing = await traffic.wait_received({"lidar": 5, "gps": 1, "imu": 0}, timeout_s=0.05)
    assert missing == {"lidar": 3, "gps": 1}
    assert loop.time() - started >= 0.05


def test_sent_lines_are_counted_apart_from_received_ones() -> None:
    traffic = Traffic()
    traffic.add_sent("chassis")
    traffic.add_sent("chassis", 2)
    assert traffic.sent["chassis"] == 3
    assert traffic.received["chassis"] == 0
    assert traffic.missing({"chassis": 1}) == {"chassis": 1}
