"""Order reading benchmark: how long the largest order the vehicle takes holds the event loop,
read whole (``Order.model_validate_json``, as before) and in slices (``order_reading``).

The order: ``MAX_NODES`` nodes, each with two HARD ``wait`` actions of ten parameters, and
the edges between them, about 1.1 MB (just over ``fleet.max_message_bytes``' 1 MiB default,
so an upper bound). The garbage collector's view is the daemon's: everything imported is
frozen first (``gc.freeze``, as ``navd run`` does). Printed: the loop's largest gap while
one order is read, median and largest over the runs, each way, and their ratio.
"""

from __future__ import annotations

import asyncio
import gc
import json
import statistics
import time
from typing import Any

from navd.fleet.order_reading import read_now, read_order
from navd.fleet.vda5050 import MAX_NODES

__all__ = ["largest_order", "run", "straight_order"]


def largest_order() -> bytes:
    """The order read (see the module docstring)."""
    parameters = [{"key": f"k{k}", "value": "v" * 8} for k in range(10)]
    return json.dumps(straight_order(MAX_NODES, actions=2, parameters=parameters)).encode()


def straight_order(nodes: int, *, actions: int, parameters: list[dict[str, Any]]) -> dict[str, Any]:
    """A new order for vehicle navd/r1: ``nodes`` released nodes 0.5 m apart along x, each
    with ``actions`` HARD ``wait`` actions of ``parameters``, and the edges between them."""
    action = {"actionType": "wait", "blockingType": "HARD", "actionParameters": parameters}
    return {
        "headerId": 1,
        "timestamp": "2026-12-07T12:00:00.000Z",
        "version": "2.1.0",
        "manufacturer": "navd",
        "serialNumber": "r1",
        "orderId": "o",
        "orderUpdateId": 0,
        "nodes": [
            {
                "nodeId": f"n{i}",
                "sequenceId": 2 * i,
                "released": True,
                "nodePosition": {"x": 0.5 * i, "y": 0.0, "mapId": "map"},
                "actions": [action | {"actionId": f"a{i}-{j}"} for j in range(actions)],
            }
            for i in range(nodes)
        ],
        "edges": [
            {
                "edgeId": f"e{i}",
                "sequenceId": 2 * i + 1,
                "released": True,
                "startNodeId": f"n{i}",
                "endNodeId": f"n{i + 1}",
                "actions": [],
            }
            for i in range(nodes - 1)
        ],
    }


async def _largest_gap_ms(raw: bytes, sliced: bool) -> float:
    """[ms] the largest gap between two turns of another task while ``raw`` is read."""
    gaps: list[float] = []
    reading = True

    async def turns() -> None:
        last = time.perf_counter()
        while reading:
            await asyncio.sleep(0)
            now = time.perf_counter()
            gaps.append(now - last)
            last = now

    other = asyncio.ensure_future(turns())
    await asyncio.sleep(0)
    if sliced:
        await read_order(raw)
    else:
        read_now(raw)
    reading = False
    await other
    return 1000.0 * max(gaps)


def run(repeats: int = 9) -> dict[str, object]:
    """The figures (see the module docstring)."""
    raw = largest_order()
    gc.collect()
    gc.freeze()
    whole = [asyncio.run(_largest_gap_ms(raw, sliced=False)) for _ in range(repeats)]
    sliced = [asyncio.run(_largest_gap_ms(raw, sliced=True)) for _ in range(repeats)]
    return {
        "order_bytes": len(raw),
        "nodes": MAX_NODES,
        "whole_gap_ms_median": round(statistics.median(whole), 1),
        "whole_gap_ms_max": round(max(whole), 1),
        "sliced_gap_ms_median": round(statistics.median(sliced), 1),
        "sliced_gap_ms_max": round(max(sliced), 1),
        "whole_over_sliced": round(statistics.median(whole) / statistics.median(sliced), 2),
    }
