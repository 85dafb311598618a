from __future__ import annotations

import asyncio

from navd.lifecycle.line_counts import LineCounts


async def test_wait_received_returns_when_every_named_count_is_reached() -> None:
    counts = LineCounts()
    counts.add_received("imu", 3)

    async def arrive() -> None:
        for _ in range(4):
            await asyncio.sleep(0.01)
            counts.add_received("lidar")

    feeder = asyncio.create_task(arrive())
    missing = await counts.wait_received({"imu": 3, "lidar": 4}, timeout_s=5.0)
    await feeder
    assert missing == {}
    assert counts.received["lidar"] == 4


async def test_wait_received_reports_what_did_not_come_within_the_timeout() -> None:
    counts = LineCounts()
    counts.add_received("lidar", 2)
    loop = asyncio.get_running_loop()
    started = loop.time()
    missing = await counts.wait_received({"lidar": 5, "gps": 1, "imu": 0}, timeout_s=0.05)
    assert missing == {"lidar": 3, "gps": 1}
    assert loop.time() - started >= 0.05


def test_sent_lines_are_counted_apart_from_received_ones() -> None:
    counts = LineCounts()
    counts.add_sent("chassis")
    counts.add_sent("chassis", 2)
    assert counts.sent["chassis"] == 3
    assert counts.received["chassis"] == 0
    assert counts.missing({"chassis": 1}) == {"chassis": 1}


def test_deferred_lines_are_handled_at_release_by_device_then_arrival() -> None:
    counts = LineCounts(defer=True)
    handled: list[str] = []
    for device, label in [("sim-lidar", "l1"), ("sim-imu", "i1"), ("sim-lidar", "l2")]:
        counts.take(device, 1, lambda label=label: handled.append(label))  # type: ignore[misc]
    counts.take("chassis", 2, lambda: handled.append("c1"))
    assert handled == []  # held, but already counted for the step's wait
    assert counts.missing({"sim-lidar": 2, "sim-imu": 1, "chassis": 2}) == {}
    assert counts.release() == 4
    assert handled == ["c1", "i1", "l1", "l2"]
    assert counts.release() == 0


def test_without_defer_lines_are_handled_at_once() -> None:
    counts = LineCounts()
    handled: list[int] = []
    counts.take("imu0", 3, lambda: handled.append(1))
    assert handled == [1] and counts.received["imu0"] == 3


def test_held_lines_stay_bounded_when_nobody_steps_the_clock() -> None:
    from navd.lifecycle.line_counts import MAX_HELD

    counts = LineCounts(defer=True)
    handled: list[int] = []
    for i in range(MAX_HELD + 5):
        counts.take("imu0", 1, lambda i=i: handled.append(i))  # type: ignore[misc]
    assert handled == list(range(MAX_HELD))  # the oldest were handled, in order
    assert counts.release() == 5
    assert counts.received["imu0"] == MAX_HELD + 5
