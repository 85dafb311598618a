"""The live view module in a running daemon, watched over a real WebSocket connection."""

from __future__ import annotations

import asyncio
import socket
from collections.abc import AsyncIterator, Mapping
from contextlib import asynccontextmanager
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from navd.config import parse_config
from navd.lifecycle import Daemon
from navd.lifecycle.messages import (
    CostmapUpdate,
    LaserScan,
    LocalTrajectory,
    MapUpdate,
    PoseEstimate,
    SafetyState,
    ViewInterest,
)
from navd.logs import add_log_tap, get_logger, remove_log_tap
from navd.viz import node as viz_node
from navd.viz.listener import Throttle
from navd.viz.node import VizNode
from tests.drivers.conftest import record, until
from tests.planning.test_zones import ORIGIN, SHAPE, write_mask
from tests.viz.foxglove_client import FoxgloveClient

TOPICS = {"/map", "/scan", "/tf", "/pose", "/route", "/goal", "/footprint", "/keep_out"}
TOPICS |= {"/goal_status", "/status", "/log", "/costmap", "/trajectory", "/pose/in_frame"}


@asynccontextmanager
async def viewed_daemon(
    daemon_log_level: str = "warning",
    tcp: Mapping[str, Any] | None = None,
    planning: Mapping[str, Any] | None = None,
    **viz: Any,
) -> AsyncIterator[tuple[Daemon, VizNode]]:
    """A daemon running only the live view, on a free port unless ``viz`` names one (and
    with the ``tcp`` section given, for its token)."""
    config = parse_config(
        {
            "viz": {"port": 0, "page_port": 0, **viz},
            "tcp": {"port": 0, **(tcp or {})},
            "logging": {"level": daemon_log_level},
            "planning": {
                "keep_out_zones": [[[1.0, 1.0], [2.0, 1.0], [2.0, 2.0]]],
                **(planning or {}),
            },
        }
    )
    node = VizNode()
    daemon = Daemon(config, [node], handle_signals=False)
    task = asyncio.create_task(daemon.run())
    try:
        await asyncio.wait_for(daemon.ready.wait(), 30.0)
        yield daemon, node
    finally:
        daemon.request_shutdown("test over")
        await asyncio.wait_for(task, 10.0)


def map_update(stamp: float) -> MapUpdate:
    occupancy = np.full((20, 30), -1, dtype=np.int8)
    occupancy[5:15, 5:25] = 0
    occupancy[5, 5:25] = 100
    return MapUpdate(
        stamp=stamp,
        received=stamp,
        revision=1,
        resolution_m=0.05,
        origin_x_m=-0.5,
        origin_y_m=-0.25,
        occupancy=occupancy,
    )


def scan(stamp: float) -> LaserScan:
    ranges = np.linspace(0.5, 3.0, 360).astype(np.float32)
    return LaserScan(
        stamp=stamp,
        received=stamp,
        device_id="lidar0",
        angle_min=-np.pi,
        angle_increment=2 * np.pi / 360,
        ranges=ranges,
        range_min=0.1,
        range_max=12.0,
    )


async def test_a_viewer_gets_the_state_at_once_and_then_what_changes() -> None:
    async with viewed_daemon() as (daemon, node):
        assert node.port is not None
        now = daemon.clock.now()
        daemon.bus.publish(map_update(now))  # before anyone watches
        daemon.bus.publish(SafetyState(stamp=now, received=now, reasons=("lidar stale",)))
        client = await FoxgloveClient.open(node.port)
        try:
            await client.wait_for_topics(TOPICS)
            await client.subscribe("/map", "/scan", "/footprint", "/keep_out", "/status")
            # What changes rarely arrives on subscribing, not at the next change.
            first = await client.receive_each("/map", "/footprint", "/keep_out", "/status")
            cells = np.frombuffer(first["/map"].data, dtype=np.int8).reshape(20, 30)
            np.testing.assert_array_equal(cells, map_update(now).occupancy)
            assert first["/footprint"].entities[0].frame_id == "base_link"
            assert [(p.x, p.y) for p in first["/keep_out"].entities[0].lines[0].points] == [
                (1.0, 1.0),
                (2.0, 1.0),
                (2.0, 2.0),
            ]
            status = first["/status"]
            assert status["safety"] == {"stopped": True, "reasons": ["lidar stale"]}
            # Then each scan as it comes.
            sent = scan(daemon.clock.now())
            daemon.bus.publish(sent)
            _, shown = await client.receive("/scan")
            assert shown.frame_id == "base_link"  # placed at the mount by its pose
            np.testing.assert_allclose(shown.ranges, sent.ranges, rtol=1e-6)
        finally:
            await client.close()


async def test_nothing_is_encoded_for_a_channel_nobody_watches(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    encoded: list[float] = []
    real = viz_node.scene.laser_scan

    def counting(message: LaserScan, *args: Any, **kw: Any) -> Any:
        encoded.append(message.stamp)
        return real(message, *args, **kw)

    monkeypatch.setattr(viz_node.scene, "laser_scan", counting)
    async with viewed_daemon(scan_rate_hz=100.0) as (daemon, node):
        assert node.port is not None
        client = await FoxgloveClient.open(node.port)
        try:
            await client.wait_for_topics({"/scan", "/map"})
            await client.subscribe("/map")
            for i in range(5):
                daemon.bus.publish(scan(daemon.clock.now() + i))
            assert encoded == []
            await client.subscribe("/scan")
            await asyncio.sleep(0.2)  # the subscription reaches the server
            daemon.bus.publish(scan(daemon.clock.now() + 10.0))
            await client.receive("/scan")
            assert len(encoded) == 1
        finally:
            await client.close()


async def test_a_busy_port_leaves_the_daemon_running_without_the_view() -> None:
    with socket.socket() as holder:
        holder.bind(("127.0.0.1", 0))
        holder.listen()
        busy = holder.getsockname()[1]
        said: list[dict[str, Any]] = []

        def keep(event: Mapping[str, Any]) -> None:
            said.append(dict(event))  # later processors change the event they are given

        add_log_tap(keep)
        try:
            async with viewed_daemon(port=busy) as (daemon, node):
                assert node.port is None  # no view
                assert daemon.manager.states["viz"].value == "active"
                daemon.bus.publish(scan(daemon.clock.now()))  # handlers stay harmless
        finally:
            remove_log_tap(keep)
    (line,) = [e for e in said if e["event"] == "viz_unavailable"]
    assert line["port"] == busy and "viz.port" in line["fix"]


@pytest.mark.parametrize(
    ("period_s", "arrivals", "sent"),
    [
        (0.1, [0.0, 0.09, 0.19, 0.31, 0.39, 0.52], 6),  # a jittery 10 Hz stream keeps 10 Hz
        (0.1, [0.0, 0.02, 0.04, 0.06, 0.08, 0.10, 0.12, 0.14, 0.16, 0.18, 0.20], 3),  # 50 Hz
        (1.0, [0.0, 0.5, 0.9, 1.0, 2.5], 3),
    ],
)
def test_the_throttle_keeps_a_streams_rate_under_its_cap(
    period_s: float, arrivals: list[float], sent: int
) -> None:
    throttle = Throttle()
    assert sum(throttle.due(t, period_s) for t in arrivals) == sent


async def test_log_lines_reach_the_view_with_their_level_and_fields() -> None:
    # The daemon writes info lines; the view takes warnings and worse.
    async with viewed_daemon("info", log_level="warning") as (_daemon, node):
        assert node.port is not None
        client = await FoxgloveClient.open(node.port)
        try:
            await client.wait_for_topics({"/log"})
            await client.subscribe("/log")
            await asyncio.sleep(0.2)  # the subscription reaches the server
            log = get_logger("chassis")
            log.info("not_shown", reason="below viz.log_level")
            log.warning("port_vanished", port="/dev/ttyS3")
            _, line = await client.receive("/log")
            assert line.name == "chassis"
            assert line.message == "port_vanished port=/dev/ttyS3"
            assert line.level == 3  # foxglove.Log's WARNING
        finally:
            await client.close()


async def test_the_costmap_and_trajectory_are_asked_for_only_while_watched() -> None:
    async with viewed_daemon() as (daemon, node):
        assert node.port is not None
        interest = record(daemon, ViewInterest)
        client = await FoxgloveClient.open(node.port)
        try:
            await client.wait_for_topics({"/costmap", "/trajectory"})
            await client.subscribe("/costmap")
            await until(lambda: bool(interest), timeout_s=5.0)
            assert (interest[-1].costmap, interest[-1].trajectory) == (True, False)
            now = daemon.clock.now()
            cells = np.array([[-1, 0], [99, 100]], dtype=np.int8)
            daemon.bus.publish(
                CostmapUpdate(
                    stamp=now,
                    received=now,
                    resolution_m=0.05,
                    origin_x_m=1.0,
                    origin_y_m=2.0,
                    occupancy=cells,
                )
            )
            _, grid = await client.receive("/costmap")
            shown = np.frombuffer(grid.data, dtype=np.int8).reshape(2, 2)
            np.testing.assert_array_equal(shown, cells)
            assert (grid.pose.position.x, grid.pose.position.y) == (1.0, 2.0)
            await client.subscribe("/trajectory")
            await until(lambda: interest[-1].trajectory, timeout_s=5.0)
            daemon.bus.publish(
                LocalTrajectory(
                    stamp=now,
                    received=now,
                    goal_id="g",
                    linear_mps=0.3,
                    angular_radps=0.0,
                    points_m=np.array([[0.0, 0.0], [0.3, 0.0]]),
                )
            )
            _, line = await client.receive("/trajectory")
            assert [(p.x, p.y) for p in line.entities[0].lines[0].points] == [(0, 0), (0.3, 0)]
            await client.unsubscribe("/costmap")
            await until(lambda: not interest[-1].costmap, timeout_s=5.0)
            assert interest[-1].trajectory
        finally:
            await client.close()
        # the viewer gone, nothing is watched: the planner may stop making either
        await until(lambda: not interest[-1].trajectory, timeout_s=5.0)


async def test_zone_masks_are_shown_as_grids(tmp_path: Path) -> None:
    grey = np.full(SHAPE, 254, dtype=np.uint8)
    grey[10:20, 30:40] = 0  # a keep-out block
    yaml = write_mask(tmp_path, "keep", grey)
    async with viewed_daemon(planning={"keep_out_mask": str(yaml)}) as (_, node):
        assert node.port is not None
        client = await FoxgloveClient.open(node.port)
        try:
            await client.wait_for_topics({"/zones/keep_out", "/zones/speed"})
            await client.subscribe("/zones/keep_out")
            _, grid = await client.receive("/zones/keep_out", timeout_s=10.0)
        finally:
            await client.close()
    shown = np.frombuffer(grid.data, dtype=np.int8).reshape(SHAPE)
    assert (shown[10:20, 30:40] == 100).all() and (shown[:10] == 0).all()
    assert (grid.pose.position.x, grid.pose.position.y) == pytest.approx(ORIGIN)


async def test_the_pose_is_also_sent_as_a_pose_in_frame_for_lichtblick() -> None:
    async with viewed_daemon() as (daemon, node):
        assert node.port is not None
        client = await FoxgloveClient.open(node.port)
        try:
            await client.wait_for_topics({"/pose/in_frame"})
            assert client.channels["/pose/in_frame"].schema_name == "foxglove.PoseInFrame"
            await client.subscribe("/pose/in_frame")
            for i in range(100):  # until the subscription is in: each pose is sent once
                now = daemon.clock.now()
                stamps = {"stamp": now, "received": now}
                cov = np.diag([0.01, 0.01, 0.01])
                pose = PoseEstimate(**stamps, x_m=1.5, y_m=-0.5, yaw_rad=0.0, covariance=cov)
                daemon.bus.publish(pose)
                try:
                    _, shown = await client.receive("/pose/in_frame", timeout_s=0.2)
                    break
                except TimeoutError:
                    assert i < 99, "no pose on /pose/in_frame"
            assert shown.frame_id == "map"
            assert (shown.pose.position.x, shown.pose.position.y) == (1.5, -0.5)
        finally:
            await client.close()
