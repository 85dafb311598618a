"""The live view of the real daemon process, watched as the Foxglove app watches it."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from navd.wire import Client, ScanFrame
from tests.e2e.conftest import default_config
from tests.viz.foxglove_client import FoxgloveClient

pytestmark = pytest.mark.e2e

SCAN = ScanFrame(
    stamp=None,
    angle_min=-3.14,
    angle_increment=0.01,
    range_min=0.1,
    range_max=10.0,
    ranges=[1.5 + 0.001 * i for i in range(628)],
)


def logged(daemon: Any, event: str, timeout_s: float = 20.0) -> dict[str, Any]:
    """The daemon's log line ``event``, whether it was read already or is still to come."""
    for line in daemon.seen:
        if line.get("event") == event:
            return dict(line)
    return dict(daemon.wait_for(event, timeout_s=timeout_s))


async def test_the_defaults_serve_the_view_and_a_scan_reaches_it(
    spawn_daemon: Any, tmp_path: Path
) -> None:
    daemon = spawn_daemon("run", "--config", str(default_config(tmp_path)))
    logged(daemon, "ready")
    tcp_port = logged(daemon, "listening")["port"]
    viz_port = logged(daemon, "viz_listening")["port"]
    viewer = await FoxgloveClient.open(viz_port)
    lidar = Client("127.0.0.1", tcp_port, role="lidar", device_id="lidar0")
    try:
        await viewer.wait_for_topics({"/map", "/scan", "/tf", "/pose", "/status", "/log"})
        await viewer.subscribe("/scan", "/status")
        status: dict[str, Any] = {}
        while "modules" not in status:  # safety and localization may come before the daemon's
            _, status = await viewer.receive("/status", timeout_s=15.0)
        assert {m["name"]: m["state"] for m in status["modules"]}["viz"] == "active"
        assert status["safety"]["stopped"]  # no lidar data yet: the gate holds the robot
        deadline = time.monotonic() + 15.0
        shown = None
        while shown is None and time.monotonic() < deadline:
            lidar.send(SCAN.model_copy(update={"stamp": time.monotonic()}))
            try:
                _, shown = await viewer.receive("/scan", timeout_s=0.5)
            except TimeoutError:
                continue
        assert shown is not None, "no scan reached the view"
        assert shown.frame_id == "base_link"  # at the lidar's mount, by its pose
        np.testing.assert_allclose(shown.ranges, SCAN.ranges, rtol=1e-6)
        assert shown.start_angle == pytest.approx(-3.14)
    finally:
        lidar.close()
        await viewer.close()
