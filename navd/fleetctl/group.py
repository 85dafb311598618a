"""A group goal (seed 000): the group's centre goes to a point, its robots keep a formation
around it, all start together, and nobody runs ahead.

The centre's way runs from where the robots are (their mean) to the goal: a straight line,
or with a map the route around walls, where the group goes in a column through doors and
corridors too narrow for its formation (``way``). It is cut into steps. Every place of the
formation is to be reached facing the way on (the last one, the goal's heading), so a robot
turns while it waits for the others, not when the next step starts; a place in a column has
no heading (the column bends with the route, and a robot goes on as it came).
Each robot's VDA 5050 order is the list of its places along that way: its first node is
where it stands, the only one released, with its form-up place (at the start centre) as the
horizon; at the common start time every robot gets an update releasing the form-up place,
so all start together with nothing but standard order updates (a vehicle of any maker takes
them; seed 000's start timestamp, carried by the release itself). Then each step: only the
next place is released: once every robot has reached its place of step k, each gets an
order update releasing step k+1.
That is the formation's correction at each step: the group moves at the pace of its slowest
robot and re-forms at every step. Within a step, from the positions the robots report, one
that has come ``AHEAD_M`` farther along its step than the slowest is paused (``startPause``)
until the slowest is within ``CAUGHT_UP_M`` of it (``stopPause``): the correction by
measured positions of seed 000.

Plain logic: orders out as dicts, states in as dicts; ``navd.fleetctl.control`` does the MQTT.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

from navd.fleet import PROTOCOL_VERSION, timestamp
from navd.fleetctl.errors import GroupGoalError
from navd.fleetctl.formation import shape_error
from navd.fleetctl.group_goal import GroupGoal
from navd.fleetctl.group_map import GroupMap
from navd.fleetctl.group_route import GroupRoute, lay_out

__all__ = ["GroupDrive", "GroupGoal", "GroupMember"]

FloatArray = npt.NDArray[np.float64]
# [m] how near a node counts as traversed (the vehicles' own goal tolerance decides, this
# tells them how near they may be)
NODE_DEVIATION_M = 0.3
# [m] the first node (where a robot stands) is this forgiving: the robot is surely on it
START_DEVIATION_M = 1.0
# [m] a robot this much farther along its step than the slowest waits; it goes on once the
# slowest is within CAUGHT_UP_M
AHEAD_M = 0.1
CAUGHT_UP_M = 0.05
# [s] a vehicle whose state still disagrees this long after a pause or resume is sent it again
RESEND_S = 2.0
# [m] a robot this near another's place is in its way: the other cannot plan to it (a place
# needs a robot's radius and margin, 0.3 m, clear of the robot there, 0.28 m across its
# corners at navd's defaults, with room for the positions' noise). Farther than a triangle's
# back row is from the robot ahead at a step's start (0.78 m at 1.5 m spacing), and than a
# column's next robot is from the one ahead (0.75 m): those are paced as usual.
IN_THE_WAY_M = 0.7


@dataclass
class GroupMember:
    """One robot of the group: its vehicle names, its places, how far it has come."""

    manufacturer: str
    serial: str
    places: FloatArray  # [m] its place at each step (0: the form-up place)
    headings: FloatArray  # [rad] which way it faces at each place
    stations: FloatArray  # [m] how far along the route each place is in a column (NaN: not)
    start_xy: tuple[float, float]
    reached: int = -1  # the last place reached (-1: none yet)
    update: int = 0
    map_id: str = "map"  # the map its positions are on: its nodes are on it too
    # [s, m, m, rad, m/s] the last position heard: when (fleet control's clock), where, how fast
    position: tuple[float, float, float, float, float] | None = None
    errors: list[str] = field(default_factory=list)
    paused: bool = False  # held by the fleet control for the others to catch up
    said_paused: bool = False  # paused, as its last state said
    paused_sent_s: float = -math.inf  # [s] when the last startPause or stopPause went to it
    orders_sent: int = 0  # the headerId of its last order (each topic counts its own)

    def progress_report(self) -> dict[str, Any]:
        """How far it got: the last place reached ("last_place", -1: not even its form-up
        place) of its last ("of"), paused by the fleet control or not, its errors, and where
        it last said it was ("at_m": x, y in the map frame, None if never)."""
        at = None if self.position is None else [round(self.position[i], 2) for i in (1, 2)]
        return {
            "serial": self.serial,
            "last_place": self.reached,
            "of": int(self.places.shape[0]) - 1,
            "paused": self.paused,
            "errors": list(self.errors),
            "at_m": at,
        }


class GroupDrive:
    """One group goal being driven (see the module docstring).

    Args:
        group_id: names the orders (``<group_id>-<serial>``).
        robots: (manufacturer, serial, x [m], y [m]) of each robot, where it stands.
        goal: the group goal.
        now_unix_s: [s] wall time now (the start time is set from it).
        map_ids: the map each robot (by serial) says it is on; its nodes are put on it
            ("map" for one that has not said).
        group_map: the map the group drives on (None: a straight line, open ground).

    Raises:
        GroupGoalError: no robot, no route for the centre, or a place the group does not fit
            even in a column (``way.lay_out``).
    """

    def __init__(
        self,
        group_id: str,
        robots: list[tuple[str, str, float, float]],
        goal: GroupGoal,
        now_unix_s: float,
        *,
        map_ids: Mapping[str, str] | None = None,
        group_map: GroupMap | None = None,
    ) -> None:
        if not robots:
            raise GroupGoalError("a group needs at least one robot")
        self.group_id = group_id
        self.goal = goal
        here = np.array([(x, y) for _, _, x, y in robots], dtype=np.float64)
        self.way: GroupRoute = lay_out(
            here,
            (goal.x_m, goal.y_m),
            goal_heading_rad=goal.heading_rad,
            formation=goal.formation,
            spacing_m=goal.spacing_m,
            step_m=goal.step_m,
            group_map=group_map,
        )
        self.members: list[GroupMember] = []
        for i, (maker, serial, x, y) in enumerate(robots):
            way = self.way
            member = GroupMember(
                maker, serial, way.places_m[i], way.headings_rad[i], way.stations_m[i], (x, y)
            )
            member.map_id = (map_ids or {}).get(serial, member.map_id)
            self.members.append(member)
        self.start_unix_s = now_unix_s + goal.start_delay_s
        self.released = -1  # the last place released to everyone (-1: where they stand)

    @property
    def steps(self) -> int:
        """How many places each robot goes through (form-up place included)."""
        return int(self.members[0].places.shape[0])

    @property
    def done(self) -> bool:
        """Every robot is at its last place."""
        return all(m.reached == self.steps - 1 for m in self.members)

    # --- orders ---------------------------------------------------------------------------

    def first_orders(self) -> list[tuple[GroupMember, dict[str, Any]]]:
        """Each robot's first order: where it stands, released; its form-up place as the
        horizon (``start`` releases it)."""
        out = []
        for m in self.members:
            start_node = self._node(m, -1, released=True, at=m.start_xy)
            start_node["nodePosition"]["allowedDeviationXY"] = START_DEVIATION_M
            out.append((m, self._order(m, [start_node, self._node(m, 0, released=False)])))
        return out

    def start(self, now_unix_s: float) -> list[tuple[GroupMember, dict[str, Any]]]:
        """At the start time (once): the update to each robot releasing its form-up place,
        the next place as the horizon; before it, or after, nothing."""
        if self.released >= 0 or now_unix_s < self.start_unix_s:
            return []
        return self._release()

    def on_state(
        self, serial: str, state: dict[str, Any]
    ) -> list[tuple[GroupMember, dict[str, Any]]]:
        """A robot's state: its progress; when all have reached the released place, the
        next one is released to each (the updates to send)."""
        member = next((m for m in self.members if m.serial == serial), None)
        if member is None:
            return []
        ours = self._order_id(member)
        # a refusal of our order names it; the state may still carry the order before it
        member.errors = [
            str(e.get("errorType"))
            for e in state.get("errors", [])
            if isinstance(e, dict)
            and (
                state.get("orderId") == ours
                or any(r.get("referenceValue") == ours for r in e.get("errorReferences", []))
            )
        ]
        member.said_paused = state.get("paused") is True
        if state.get("orderId") != ours:
            return []
        member.reached = max(member.reached, _place_of(int(state.get("lastNodeSequenceId", 0))))
        if not 0 <= self.released < self.steps - 1:  # not started, or all released
            return []
        if any(m.reached < self.released for m in self.members):
            return []
        return self._release()

    def _release(self) -> list[tuple[GroupMember, dict[str, Any]]]:
        """Release the next place to every robot: the updates."""
        self.released += 1
        out = []
        for m in self.members:
            k = self.released
            at = m.start_xy if k == 0 else None  # the place before the form-up: where it stood
            last = self._node(m, k - 1, released=True, at=at)
            if k == 0:
                last["nodePosition"]["allowedDeviationXY"] = START_DEVIATION_M
            nodes = [last, self._node(m, k, released=True)]
            if k + 1 < self.steps:
                nodes.append(self._node(m, k + 1, released=False))
            m.update += 1
            out.append((m, self._order(m, nodes)))
        return out

    def on_position(self, serial: str, message: dict[str, Any], heard_s: float) -> None:
        """A robot's visualization (or state) heard at ``heard_s`` [s]: where it is."""
        member = next((m for m in self.members if m.serial == serial), None)
        where = message.get("agvPosition")
        if member is None or not isinstance(where, dict):
            return
        velocity = message.get("velocity")
        speed = velocity.get("vx", 0.0) if isinstance(velocity, dict) else 0.0
        try:
            x, y, yaw = float(where["x"]), float(where["y"]), float(where.get("theta", 0.0))
        except (KeyError, TypeError, ValueError):
            return  # a malformed position: the last good one stands
        member.position = (
            heard_s,
            x,
            y,
            yaw,
            float(speed) if isinstance(speed, int | float) else 0.0,
        )

    def shape_error_m(self, now_s: float) -> float:
        """[m] the group's shape error at ``now_s``: each robot's last heard position carried
        on to then at its speed (they are heard at different times), against where the way
        puts it at the group's progress through the released step (the mean of the robots'
        shares of it; ``GroupRoute.target_m``), laid over as well as it fits
        (``formation.shape_error``). NaN until every robot has said where it is."""
        if self.released < 0 or any(m.position is None for m in self.members):
            return math.nan
        xy = np.array([self._carried(m, now_s) for m in self.members])
        k = self.released
        shares = [1.0 if m.reached >= k else self._share(m, k, now_s) for m in self.members]
        return shape_error(xy, self.way.target_m(k, float(np.mean(shares))))

    def corrections(self, now_s: float) -> list[tuple[GroupMember, str]]:
        """The pauses and resumes (``startPause`` / ``stopPause``) that keep the robots abreast
        within the released step, from their positions carried on to ``now_s``: a robot that
        has come a larger share of its step than the slowest, by AHEAD_M or more of its own
        step, waits (steps differ in length where the shape changes or the route bends). A
        robot in the way of a slower one (within IN_THE_WAY_M of its place: in a column, the
        robot ahead may stand where the next one goes) is never held: holding it would hold
        the slower one for good (its place taken, it cannot even plan). A held robot that has
        reached its place, or has nothing to drive in a newly released step, is let go."""
        out = self._resent(now_s)
        k = self.released
        if k < 1 or any(m.position is None for m in self.members):
            return out
        # a robot whose place does not move this step has nothing to drive: it is no one's pace
        going = [m for m in self.members if m.reached < k and self._length(m, k) > 1e-9]
        share = {m.serial: self._share(m, k, now_s) for m in going}
        slowest = min(share.values(), default=math.inf)
        for m in self.members:
            mine = share.get(m.serial)
            ahead = math.inf if mine is None else (mine - slowest) * self._length(m, k)
            blocking = mine is not None and any(
                share[o.serial] < mine and self._in_the_way(m, o, k, now_s)
                for o in going
                if o is not m
            )
            if not m.paused and mine is not None and ahead > AHEAD_M and not blocking:
                m.paused, m.paused_sent_s = True, now_s
                out.append((m, "startPause"))
            elif m.paused and (mine is None or ahead < CAUGHT_UP_M or blocking):
                # (mine None: at its place, or nothing to drive this step: nothing to hold)
                m.paused, m.paused_sent_s = False, now_s
                out.append((m, "stopPause"))
        return out

    def _resent(self, now_s: float) -> list[tuple[GroupMember, str]]:
        """The pause or resume sent again to a vehicle whose state still says otherwise
        RESEND_S after it went: a vehicle may refuse one (vda-5050-lib's refuses a stopPause
        while it is "not yet paused", a startPause while "already paused"), and one left
        paused would hold the group for good."""
        out = []
        for m in self.members:
            paced = m.paused_sent_s > -math.inf  # (a robot paused by someone else is theirs)
            if paced and m.said_paused != m.paused and now_s - m.paused_sent_s > RESEND_S:
                m.paused_sent_s = now_s
                out.append((m, "startPause" if m.paused else "stopPause"))
        return out

    @staticmethod
    def _length(m: GroupMember, k: int) -> float:
        """[m] the length of robot ``m``'s step k (from place k - 1 to place k)."""
        return float(np.hypot(*(m.places[k] - m.places[k - 1])))

    def _in_the_way(self, m: GroupMember, other: GroupMember, k: int, now_s: float) -> bool:
        """Robot ``m`` stands within IN_THE_WAY_M of ``other``'s place k."""
        return float(np.hypot(*(self._carried(m, now_s) - other.places[k]))) < IN_THE_WAY_M

    @staticmethod
    def _carried(m: GroupMember, now_s: float) -> FloatArray:
        """[m] where robot ``m`` is at ``now_s``: its last heard position carried on."""
        assert m.position is not None
        t, x, y, yaw, v = m.position
        return np.array([x + v * math.cos(yaw) * (now_s - t), y + v * math.sin(yaw) * (now_s - t)])

    def _progress(self, m: GroupMember, k: int, now_s: float) -> float:
        """[m] how far robot ``m`` has come along its step from place k - 1 to place k."""
        x, y = self._carried(m, now_s)
        a, b = m.places[k - 1], m.places[k]
        step = b - a
        length = float(np.hypot(*step))
        if length < 1e-9:
            return 0.0
        along = ((x - a[0]) * step[0] + (y - a[1]) * step[1]) / length
        return float(np.clip(along, 0.0, length))

    def _share(self, m: GroupMember, k: int, now_s: float) -> float:
        """How much (0..1) of step k robot ``m`` has driven."""
        if k < 1:
            return 0.0
        length = self._length(m, k)
        return self._progress(m, k, now_s) / length if length > 1e-9 else 1.0

    def _order_id(self, m: GroupMember) -> str:
        return f"{self.group_id}-{m.serial}"

    def _node(
        self, m: GroupMember, k: int, *, released: bool, at: tuple[float, float] | None = None
    ) -> dict[str, Any]:
        """Node of place ``k`` (-1: where the robot stood), sequence id 2 (k + 1)."""
        x, y = at if at is not None else (float(m.places[k, 0]), float(m.places[k, 1]))
        position: dict[str, Any] = {
            "x": x,
            "y": y,
            "mapId": m.map_id,
            "allowedDeviationXY": NODE_DEVIATION_M,
        }
        # facing the way on, so the next step starts without turning on the spot; but a
        # robot in a column follows a bending route: it goes on from one place to the next
        # as it came (a turn on the spot at every place would hold the column up)
        if k == self.steps - 1 or (k >= 0 and not math.isfinite(m.stations[k])):
            position["theta"] = math.remainder(float(m.headings[k]), math.tau)
        return {
            "nodeId": f"{self.group_id}-{m.serial}-{k + 1}",
            "sequenceId": 2 * (k + 1),
            "released": released,
            "nodePosition": position,
            "actions": [],
        }

    def _order(self, m: GroupMember, nodes: list[dict[str, Any]]) -> dict[str, Any]:
        edges = [
            {
                "edgeId": f"{a['nodeId']}>{b['nodeId']}",
                "sequenceId": a["sequenceId"] + 1,
                "released": a["released"] and b["released"],
                "startNodeId": a["nodeId"],
                "endNodeId": b["nodeId"],
                "maxSpeed": self.goal.speed_mps,
                "actions": [],
            }
            for a, b in itertools.pairwise(nodes)
        ]
        m.orders_sent += 1
        return {
            "headerId": m.orders_sent,
            "timestamp": timestamp(self.start_unix_s - self.goal.start_delay_s),
            "version": PROTOCOL_VERSION,
            "manufacturer": m.manufacturer,
            "serialNumber": m.serial,
            "orderId": self._order_id(m),
            "orderUpdateId": m.update,
            "nodes": nodes,
            "edges": edges,
        }


def _place_of(sequence_id: int) -> int:
    """The place index of a node's sequence id (node 2 (k + 1) is place k)."""
    return sequence_id // 2 - 1
