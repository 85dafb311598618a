"""Driving a group goal through the vehicles' orders (``group.GroupDrive``).

It listens to every vehicle of the interface (``connection`` and ``state``), asks the ones
in the group for a fresh state (``stateRequest``), sends each its order, then an update each
time the group is ready for the next step, until all are at their last place, one fails, or
the time is up.
"""

from __future__ import annotations

import asyncio
import json
import math
import time
import uuid
from collections.abc import Callable, Mapping
from typing import Any

import aiomqtt
import numpy as np

from navd.fleet import MAJOR_VERSION, PROTOCOL_VERSION, timestamp
from navd.fleetctl.errors import GroupGoalError
from navd.fleetctl.group import GroupDrive, GroupGoal, GroupMember
from navd.fleetctl.group_map import GroupMap
from navd.fleetctl.view import (
    HEADERS,
    QOS,
    FleetView,
    fleet_view,
    instant_action,
    master_client,
    spoken,
)

__all__ = ["drive_group", "one_map"]

# [s] the group's shape is measured (and corrected) at most this often, not on every message
MEASURE_EVERY_S = 0.1
# errors that end a group goal: the vehicle cannot do its part
FATAL_ERRORS = ("validationError", "orderError", "orderUpdateError")


async def drive_group(
    broker_url: str,
    goal: GroupGoal,
    *,
    serials: list[str] | None = None,
    interface: str = "uagv",
    timeout_s: float = 600.0,
    report: Callable[[dict[str, Any]], None] = lambda _: None,
    group_map: GroupMap | None = None,
    map_id: str | None = None,
) -> dict[str, Any]:
    """Drive ``goal`` with the vehicles ``serials`` (None: every ONLINE one with a position);
    ``report`` hears each step. On ``group_map`` the centre's way goes round walls and the
    group goes in a column where its formation does not fit (``way``); without one, straight.
    The summary: "reached" true or the reason, the largest shape error [m] once the group had
    formed up, the shapes along the way, the centre's route [m], the time it took, and how far
    each robot got ("members": the last place it reached, paused or not, its errors, where it
    last was).

    Raises:
        GroupGoalError: no vehicle to drive, one asked for is not there, robots on different maps
            or on another than ``map_id`` (the one they report), or no way for the group on
            ``group_map`` (why, named).
    """
    view = await fleet_view(broker_url, interface)
    robots = _members(view, serials)
    maps = {v.serial: v.map_id for v in view.vehicles.values() if v.map_id is not None}
    one_map({r[1]: maps[r[1]] for r in robots if r[1] in maps}, map_id)
    group = GroupDrive(
        f"group-{uuid.uuid4().hex[:6]}",
        robots,
        goal,
        time.time(),
        map_ids=maps,
        group_map=group_map,
    )
    began = time.monotonic()
    outcome: dict[str, Any] = {"reached": False}
    async with master_client(broker_url) as client:
        run = _GroupRun(client, f"{interface}/{MAJOR_VERSION}", group, view, report)
        await run.start()
        loop = asyncio.get_running_loop()
        deadline = loop.time() + timeout_s
        while not group.done:
            left = deadline - loop.time()
            if left <= 0:
                outcome["reason"] = f"not there within {timeout_s:g} s"
                break
            await run.start_if_due()
            if group.released < 0:  # wake at the start time, whatever comes meanwhile
                left = min(left, max(group.start_unix_s - time.time(), 0.0) + 0.01)
            try:
                message = await asyncio.wait_for(anext(client.messages), left)
            except TimeoutError:
                continue
            fatal = await run.hear(str(message.topic), bytes(message.payload))
            if fatal:
                outcome["reason"] = fatal
                break
        else:
            outcome["reached"] = True
        if not outcome["reached"]:
            await run.give_up()  # no robot is left paused, or holding a half-driven order
        else:
            await run.let_go()  # a robot the group held at the end is held no more
    outcome.update(
        group=group.group_id,
        robots=[m.serial for m in group.members],
        formation=goal.formation,
        shapes=group.way.shape_summary(),
        route_m=np.round(group.way.route_m, 2).tolist(),
        max_shape_error_m=round(run.worst_formed_m, 3),
        seconds=round(time.monotonic() - began, 1),
        members=[m.progress_report() for m in group.members],
    )
    return outcome


def one_map(map_ids: Mapping[str, str], expected: str | None = None) -> None:
    """Refuse a group whose robots (by serial, the ``agvPosition.mapId`` each reports, their
    ``slam.map_name``) are not all on one map, or not on ``expected``: one group's way is laid
    out on one map.

    Raises:
        GroupGoalError: naming each robot's map.
    """
    maps = set(map_ids.values()) | ({expected} if expected is not None else set())
    if len(maps) > 1:
        said = ", ".join(f"{serial} on {map_ids[serial]!r}" for serial in sorted(map_ids))
        wanted = f" (--map-id {expected!r})" if expected is not None else ""
        raise GroupGoalError(
            f"the robots are not all on one map{wanted}: {said}; a robot reports its "
            "slam.map_name (not the name of its slam.load_map file): set it alike on them"
        )


def _members(view: FleetView, serials: list[str] | None) -> list[tuple[str, str, float, float]]:
    """(manufacturer, serial, x, y) of the vehicles to drive: ``serials``, or every one
    online with a position.

    Raises:
        GroupGoalError: none, or one of ``serials`` is not online with a position.
    """
    ready = [v for v in view.vehicles.values() if v.connection == "ONLINE" and v.position]
    if serials is not None:
        missing = [s for s in serials if s not in {v.serial for v in ready}]
        if missing:
            seen = ", ".join(sorted(v.serial for v in ready)) or "none"
            raise GroupGoalError(
                f"vehicle {', '.join(missing)} is not online with a position (online: {seen})"
            )
        ready = [v for v in ready if v.serial in serials]
    if not ready:
        raise GroupGoalError("no vehicle is online with a position on the broker")
    return [(v.manufacturer, v.serial, *v.position) for v in ready if v.position is not None]


class _GroupRun:
    """One group goal on the broker: its orders out, the vehicles' news in."""

    def __init__(
        self,
        client: aiomqtt.Client,
        prefix: str,
        group: GroupDrive,
        view: FleetView,
        report: Callable[[dict[str, Any]], None],
    ) -> None:
        self.client, self.prefix, self.group, self.view = client, prefix, group, view
        self.report = report
        self.worst_formed_m = 0.0  # the largest shape error once the group had formed up
        self.worst_step_m = 0.0  # the largest shape error in the step being driven
        self._pending: list[tuple[Any, str]] = []  # pauses and resumes to send
        self._actions = 0
        self._measured_s = -math.inf
        self._error_m = math.nan

    async def start(self) -> None:
        await self.client.subscribe(f"{self.prefix}/+/+/state", qos=1)
        await self.client.subscribe(f"{self.prefix}/+/+/visualization", qos=0)
        group = self.group
        await self._send(group.first_orders())
        self.report(
            {
                "event": "sent",
                "group": group.group_id,
                "robots": [m.serial for m in group.members],
                "steps": group.steps,
                "shapes": group.way.shape_summary(),
            }
        )

    async def hear(self, topic: str, payload: bytes) -> str | None:
        """Take a vehicle's message; why the group goal must end, or None."""
        group = self.group
        if topic.endswith("/visualization"):
            try:
                body = json.loads(payload)
            except (ValueError, RecursionError):
                return None
            if isinstance(body, dict):
                group.on_position(topic.split("/")[3], body, time.monotonic())
                self._measure()
                await self._correct()
            return None
        heard = self.view.hear(topic, payload)
        if heard is None or heard[1] != "state" or heard[0].state is None:
            return None
        vehicle, state = heard[0], heard[0].state
        group.on_position(vehicle.serial, state, time.monotonic())
        before = group.released
        await self._send(group.on_state(vehicle.serial, state))
        error = self._measure(now_or_never=group.released != before)
        await self._correct()
        if group.released != before:
            self.report(
                {
                    "event": "step",
                    "released": group.released,
                    "of": group.steps - 1,
                    "shape": group.way.shapes[group.released],
                    "shape_error_m": round(error, 3),
                    "worst_on_the_way_m": round(self.worst_step_m, 3),  # to this step
                }
            )
            self.worst_step_m = 0.0
        fatal = sorted({e for m in group.members for e in m.errors if e in FATAL_ERRORS})
        return f"a vehicle refused its order: {', '.join(fatal)}" if fatal else None

    async def start_if_due(self) -> None:
        """At the start time, release every robot's form-up place (all start together)."""
        released = self.group.start(time.time())
        if released:
            await self._send(released)
            self.report({"event": "started", "group": self.group.group_id})

    def _measure(self, *, now_or_never: bool = False) -> float:
        """The shape error now (and the corrections it calls for), at most every
        MEASURE_EVERY_S unless ``now_or_never``."""
        now = time.monotonic()
        if not now_or_never and now - self._measured_s < MEASURE_EVERY_S:
            return self._error_m
        self._measured_s = now
        for member, action in self.group.corrections(now):
            self._pending.append((member, action))
        error = self.group.shape_error_m(now)
        if self.group.released >= 1 and math.isfinite(error):  # formed up (place 0 reached)
            self.worst_formed_m = max(self.worst_formed_m, error)
            self.worst_step_m = max(self.worst_step_m, error)
        self._error_m = error
        return error

    async def give_up(self) -> None:
        """Cancel every member's order, and let the ones the group paused go."""
        for member in self.group.members:
            await self._instant(member, "cancelOrder")
        await self.let_go()

    async def let_go(self) -> None:
        """Send ``stopPause`` to every member the group holds paused (the goal is over)."""
        for member in self.group.members:
            if member.paused or (member.said_paused and member.paused_sent_s > -math.inf):
                await self._instant(member, "stopPause")
                member.paused = False

    async def _instant(self, member: GroupMember, kind: str) -> None:
        self._actions += 1
        topic = f"{self.prefix}/{member.manufacturer}/{member.serial}/instantActions"
        message = instant_action(
            member.manufacturer,
            member.serial,
            HEADERS.next(topic),
            kind,
            f"{self.group.group_id}-{kind}-{self._actions}",
            version=self._version(member),
        )
        await self.client.publish(topic, json.dumps(message), qos=QOS)

    def _version(self, member: GroupMember) -> str:
        """The version ``member`` speaks (``Vehicle.version``)."""
        vehicle = self.view.vehicles.get(f"{member.manufacturer}/{member.serial}")
        return vehicle.version if vehicle is not None else PROTOCOL_VERSION

    async def _correct(self) -> None:
        """Send the pauses and resumes the group asked for."""
        pending, self._pending = self._pending, []
        for member, action in pending:
            await self._instant(member, action)

    async def _send(self, orders: list[tuple[Any, dict[str, Any]]]) -> None:
        for member, order in orders:
            topic = f"{self.prefix}/{member.manufacturer}/{member.serial}/order"
            said = spoken(order, self._version(member)) | {"timestamp": timestamp(time.time())}
            await self.client.publish(topic, json.dumps(said), qos=QOS)
