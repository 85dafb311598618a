"""Nothing from outside stalls the loop that drives the wheels: the real daemon, driven by
hand on a chassis pseudo-terminal, as a VDA 5050 vehicle on a real mosquitto, is sent a 50 MB
order; the wheel lines keep their rhythm and the memory comes back."""

from __future__ import annotations

import asyncio
import json
import time
from pathlib import Path
from typing import Any

from tests.e2e.driving import driven_daemon
from tests.fleet.broker import Broker

MAX_GAP_S = 0.3  # [s] the most between two wheel lines (they come every 50 ms)
MAX_GROWTH_MB = 100.0


def _rss_mb(pid: int) -> float:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024.0
    raise AssertionError("no VmRSS")


def _huge_order(serial: str) -> bytes:
    """A well-formed order of ~50 MB: 1000 nodes x 10 actions x 100 parameters."""
    parameters = [{"key": f"k{k}", "value": "v" * 20} for k in range(100)]
    nodes = [
        {
            "nodeId": f"n{i}",
            "sequenceId": 2 * i,
            "released": True,
            "nodePosition": {"x": 0.0, "y": 0.0, "mapId": "map"},
            "actions": [
                {
                    "actionType": "wait",
                    "actionId": f"a{i}-{j}",
                    "blockingType": "HARD",
                    "actionParameters": parameters,
                }
                for j in range(10)
            ],
        }
        for i in range(1000)
    ]
    head = {"headerId": 1, "timestamp": "2026-12-07T12:00:00.00Z", "version": "2.1.0"}
    order = head | {
        "manufacturer": "navd",
        "serialNumber": serial,
        "orderId": "huge",
        "orderUpdateId": 0,
        "nodes": nodes,
        "edges": [],
    }
    return json.dumps(order).encode()


def test_a_50_mb_order_neither_stalls_the_wheels_nor_keeps_memory(
    spawn_daemon: Any, tmp_path: Path
) -> None:
    import aiomqtt  # noqa: PLC0415 - only where a broker runs

    broker = Broker(tmp_path)
    broker.start()
    fleet = f'[fleet]\nenabled = true\nbroker_url = "{broker.url}"\nserial_number = "r1"\n'
    try:
        with driven_daemon(spawn_daemon, tmp_path, fleet + "[viz]\nenabled = false\n") as run:
            daemon, _, wheels = run
            daemon.wait_for("fleet_connected", timeout_s=30.0)
            order = _huge_order("r1")
            assert len(order) > 50e6
            time.sleep(2.0)  # the memory after start-up settles
            before = _rss_mb(daemon.proc.pid)

            async def send() -> None:
                async with aiomqtt.Client("127.0.0.1", broker.port, identifier="master") as m:
                    await m.publish("uagv/v2/navd/r1/order", order, qos=0)

            sent = time.monotonic()
            asyncio.run(send())
            refused = daemon.wait_for("fleet_message_too_large", timeout_s=30.0)
            assert refused["bytes"] == len(order)
            time.sleep(2.0)
            after = time.monotonic()
            assert wheels.largest_gap_s(sent, after) <= MAX_GAP_S
            assert _rss_mb(daemon.proc.pid) - before <= MAX_GROWTH_MB
    finally:
        broker.stop()
