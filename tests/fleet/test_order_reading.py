"""An order read in slices is the order pydantic reads whole, and refused for the same first
reason in the same words; the event loop runs between the slices."""

from __future__ import annotations

import asyncio
import json
from typing import Any

from hypothesis import given
from hypothesis import strategies as st
from pydantic import ValidationError

from navd.bench.order_reading import largest_order, straight_order
from navd.config import NavdConfig
from navd.fleet.order_reading import SLICE, read_now, read_order
from navd.fleet.order_rules import first_problem
from navd.fleet.vda5050 import MAX_NODES


def _order(nodes: int, *, actions: int = 0) -> dict[str, Any]:
    parameters = [{"key": f"k{k}", "value": k} for k in range(3)]
    return straight_order(nodes, actions=actions, parameters=parameters)


def _alike(raw: bytes) -> None:
    """Read in slices and whole, ``raw`` gives the same order or the same first problem."""
    sliced, whole = asyncio.run(read_order(raw)), read_now(raw)
    if isinstance(whole, ValidationError):
        assert isinstance(sliced, ValidationError)
        assert first_problem(sliced) == first_problem(whole)
    else:  # (repr: a NaN in a parameter is not equal to itself)
        assert repr(sliced) == repr(whole)
        assert not isinstance(sliced, ValidationError)
        assert sliced.model_fields_set == whole.model_fields_set


def test_the_largest_order_is_the_same_read_in_slices_and_the_loop_runs_between() -> None:
    raw = json.dumps(_order(MAX_NODES, actions=2)).encode()

    async def read() -> tuple[Any, int]:
        turns = 0
        done = asyncio.Event()

        async def count() -> None:
            nonlocal turns
            while not done.is_set():
                turns += 1
                await asyncio.sleep(0)

        counter = asyncio.ensure_future(count())
        await asyncio.sleep(0)
        order = await read_order(raw)
        done.set()
        await counter
        return order, turns

    order, turns = asyncio.run(read())
    assert order == read_now(raw)
    # the other task ran between the slices of nodes and of edges, not once at the end
    assert turns >= 2 * (MAX_NODES // SLICE) - 2


def test_what_whole_reading_refuses_is_refused_for_the_same_reason() -> None:
    base = _order(3 * SLICE, actions=1)
    bad_node = json.loads(json.dumps(base))
    bad_node["nodes"][SLICE + 5]["sequenceId"] = -1  # in the second slice
    bad_edge = json.loads(json.dumps(base))
    bad_edge["edges"][2 * SLICE]["maxSpeed"] = 0
    too_many = _order(MAX_NODES + 1)
    no_edges = {k: v for k, v in base.items() if k != "edges"}
    bad_head = base | {"orderId": ""}
    cases = [
        json.dumps(bad_node).encode(),
        json.dumps(bad_edge).encode(),
        json.dumps(too_many).encode(),
        json.dumps(no_edges).encode(),
        json.dumps(bad_head).encode(),
        # (a NaN in an action's parameter: pydantic's JSON takes it; so must the slices)
        json.dumps(base).replace('"value": 1', '"value": NaN').encode(),
        json.dumps(base).replace('"x": 1.0', '"x": Infinity').encode(),
        b"[" + json.dumps(base).encode() + b"]",
        json.dumps(base).encode()[:-10],  # cut short
        b"",
    ]
    for raw in cases:
        _alike(raw)
    refused = asyncio.run(read_order(cases[0]))
    assert isinstance(refused, ValidationError)
    assert first_problem(refused).startswith(f"nodes.{SLICE + 5}.sequenceId: ")


_JUNK = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(-3, 3),
    st.floats(allow_nan=False, allow_infinity=False, width=32),
    st.text(max_size=3),
    st.sampled_from(["true", "1", "1.0", "HARD", "map"]),
)


@given(
    nodes=st.integers(1, 3 * SLICE),
    spoilt=st.lists(
        st.tuples(
            st.sampled_from(["nodes", "edges"]),
            st.integers(0, 3 * SLICE),
            st.sampled_from(
                ["nodeId", "edgeId", "sequenceId", "released", "actions", "maxSpeed", "endNodeId"]
            ),
            _JUNK,
        ),
        max_size=3,
    ),
)
def test_any_order_reads_alike_in_slices_and_whole(
    nodes: int, spoilt: list[tuple[str, int, str, Any]]
) -> None:
    order = _order(nodes, actions=1)
    for part, index, key, value in spoilt:
        items = order[part]
        if items:
            items[index % len(items)][key] = value
    _alike(json.dumps(order).encode())


def test_the_benchmarks_order_is_one_the_vehicle_takes_at_its_largest() -> None:
    raw = largest_order()
    assert len(raw) > NavdConfig().fleet.max_message_bytes  # an upper bound of what is read
    order = read_now(raw)
    assert not isinstance(order, ValidationError), order
    assert len(order.nodes) == MAX_NODES
