from __future__ import annotations

import asyncio

from navd.lifecycle.line_counts import Traffic


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


def test_deferred_lines_are_handled_at_release_by_device_then_arrival() -> None:
    traffic = Traffic(defer=True)
    handled: list[str] = []
    for device, label in [("sim-lidar", "l1"), ("sim-imu", "i1"), ("sim-lidar", "l2")]:
        traffic.take(device, 1, lambda label=label: handled.append(label))  # type: ignore[misc]
    traffic.take("chassis", 2, lambda: handled.append("c1"))
    assert handled == []  # held, but already counted for the step's wait
    assert traffic.missing({"sim-lidar": 2, "sim-imu": 1, "chassis": 2}) == {}
    assert traffic.release() == 4
    assert handled == ["c1", "i1", "l1", "l2"]
    assert traffic.release() == 0


def test_without_defer_lines_are_handled_at_once() -> None:
    traffic = Traffic()
    handled: list[int] = []
    traffic.take("imu0", 3, lambda: handled.append(1))
    assert handled == [1] and traffic.received["imu0"] == 3


def test_held_lines_stay_bounded_when_nobody_steps_the_clock() -> None:
    from navd.lifecycle.line_counts import MAX_HELD

    traffic = Traffic(defer=True)
    handled: list[int] = []
    for i in range(MAX_HELD + 5):
        traffic.take("imu0", 1, lambda i=i: handled.append(i))  # type: ignore[misc]
    assert handled == list(range(MAX_HELD))  # the oldest were handled, in order
    assert traffic.release() == 5
    assert traffic.received["imu0"] == MAX_HELD + 5
