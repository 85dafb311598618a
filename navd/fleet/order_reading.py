"""An order read without holding the event loop: the JSON parsed at once (the C parser,
about 10 ms for the largest order taken), then its nodes and edges checked ``SLICE`` at a
time, with the loop let run between slices. Checked whole, the largest order
(``fleet.max_message_bytes``, 1 MiB) held the loop that drives the wheels for about 45 ms
here, 0.15 s on the board: pydantic holds the GIL throughout, so a thread frees nothing.

What is taken is the same ``Order`` that ``Order.model_validate_json`` makes; anything it
would refuse is handed to it, so the refusal (and its wording) is its own.
"""

from __future__ import annotations

import asyncio
import json
from typing import Any

from pydantic import TypeAdapter, ValidationError

from navd.fleet.vda5050 import MAX_NODES, Edge, Node, Order, OrderHead

__all__ = ["SLICE", "read_now", "read_order"]

SLICE = 32  # nodes or edges checked between two turns of the loop (~0.1-1 ms of work)

_NODES: TypeAdapter[list[Node]] = TypeAdapter(list[Node])
_EDGES: TypeAdapter[list[Edge]] = TypeAdapter(list[Edge])


class _ConstantError(ValueError):
    """Something only pydantic's own reading can judge (NaN or infinity in the JSON)."""


def _no_constant(name: str) -> Any:
    raise _ConstantError(name)


async def read_order(raw: bytes) -> Order | ValidationError:
    """The order ``raw`` holds, read in slices, or why it is not one (``read_now``'s)."""
    order = await _in_slices(raw)
    return order if order is not None else read_now(raw)


def read_now(raw: bytes) -> Order | ValidationError:
    """The order ``raw`` holds, read whole on the spot, or why it is not one."""
    try:
        return Order.model_validate_json(raw)
    except ValidationError as err:
        return err


async def _in_slices(raw: bytes) -> Order | None:
    """The order, or None where whole reading must judge it."""
    try:
        body = json.loads(raw, parse_constant=_no_constant)
    except (ValueError, RecursionError):
        return None
    if not isinstance(body, dict):
        return None
    nodes, edges = body.get("nodes"), body.get("edges")
    if not (isinstance(nodes, list) and isinstance(edges, list)):
        return None
    if not (1 <= len(nodes) <= MAX_NODES and len(edges) <= MAX_NODES):
        return None
    try:
        head = OrderHead.model_validate(body)
        taken_nodes: list[Node] = []
        for start in range(0, len(nodes), SLICE):
            await asyncio.sleep(0)
            taken_nodes += _NODES.validate_python(nodes[start : start + SLICE])
        taken_edges: list[Edge] = []
        for start in range(0, len(edges), SLICE):
            await asyncio.sleep(0)
            taken_edges += _EDGES.validate_python(edges[start : start + SLICE])
    except ValueError:  # (pydantic's ValidationError is one)
        return None
    return Order.model_construct(
        head.model_fields_set | {"nodes", "edges"},
        **dict(head),
        nodes=taken_nodes,
        edges=taken_edges,
    )
