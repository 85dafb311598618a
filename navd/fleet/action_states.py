"""The vehicle's actions and where each stands (VDA 5050 2.1, §6.12): every action of the
order in hand and every instant action, by id, and the last node's actions waiting their
turn. A node's actions start in their order as blocking types allow: NONE and SOFT actions
start together, a HARD one waits until those before it have ended and runs alone, and those
after it wait for its end. The only action with a duration is ``wait``."""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

from navd.fleet.vda5050 import Action

__all__ = [
    "ENDED",
    "INSTANT_ACTIONS",
    "MAX_ENDED_ACTIONS",
    "ActionState",
    "ActionStates",
    "StandstillWait",
]

INSTANT_ACTIONS = (
    "cancelOrder",
    "startPause",
    "stopPause",
    "initPosition",
    "stateRequest",
    "factsheetRequest",
)
ENDED = ("FINISHED", "FAILED")
# Finished and failed action states kept at most (the oldest go first).
MAX_ENDED_ACTIONS = 200


@dataclass
class ActionState:
    """One action and where it stands: WAITING, INITIALIZING, RUNNING, FINISHED or FAILED."""

    action: Action
    status: str = "WAITING"
    result: str | None = None
    ends_s: float = math.inf  # a running wait's end


class ActionStates:
    """Every action's state by id, and the actions waiting their turn on the last node.

    Each method that changes what the state message says returns True.
    """

    def __init__(self) -> None:
        self.states: dict[str, ActionState] = {}
        self.queued: list[Action] = []  # the last node's actions not started yet, in order

    def values(self) -> Iterable[ActionState]:
        """Every action's state, in the order they came."""
        return self.states.values()

    def register(self, actions: Iterable[Action]) -> None:
        """Actions of an order, WAITING until their node or edge is reached."""
        for action in actions:
            self.states.setdefault(action.actionId, ActionState(action))

    def forget_ended(self) -> None:
        """Drop the ended actions (a new order: only what still runs is kept)."""
        self.states = {k: v for k, v in self.states.items() if v.status not in ENDED}

    def waiting(self, action: Action) -> bool:
        """Whether ``action`` has not started yet."""
        return self.states.get(action.actionId, ActionState(action)).status == "WAITING"

    def end_waits(self, now: float) -> bool:
        """Waits whose time is up are FINISHED."""
        changed = False
        for state in self.states.values():
            if state.status == "RUNNING" and now >= state.ends_s:
                state.status, state.ends_s = "FINISHED", math.inf
                changed = True
        return changed

    def start_queued(self, now: float) -> bool:
        """Start the queued actions in order, as far as blocking types allow."""
        changed = False
        while self.queued:
            action = self.queued[0]
            running = [
                s
                for s in self.states.values()
                if s.status == "RUNNING" and s.action.actionType not in INSTANT_ACTIONS
            ]
            if any(s.action.blockingType == "HARD" for s in running):
                break
            if action.blockingType == "HARD" and running:
                break
            self.queued.pop(0)
            changed |= self._start(action, now)
            if action.blockingType == "HARD":
                break
        return changed

    def _start(self, action: Action, now: float) -> bool:
        state = self.states.setdefault(action.actionId, ActionState(action))
        if state.status != "WAITING":
            return False
        if action.actionType == "wait":
            state.status = "RUNNING"
            state.ends_s = now + float(action.parameter("duration"))
        return True

    def finish(self, action_id: str) -> bool:
        """The action is FINISHED (its edge was left), unless it had ended."""
        state = self.states.get(action_id)
        if state is None or state.status in ENDED:
            return False
        state.status, state.ends_s = "FINISHED", math.inf
        return True

    def blocking(self) -> bool:
        """Whether a SOFT or HARD action runs or waits its turn (the vehicle stands still)."""
        return any(
            s.status == "RUNNING" and s.action.blockingType != "NONE" for s in self.states.values()
        ) or any(a.blockingType != "NONE" for a in self.queued)

    def instant(self, action: Action) -> ActionState:
        """An instant action, RUNNING from now (the oldest ended ones beyond
        MAX_ENDED_ACTIONS go)."""
        state = ActionState(action, status="RUNNING")
        self.states[action.actionId] = state
        ended = [k for k, v in self.states.items() if v.status in ENDED]
        for key in ended[: max(len(ended) - MAX_ENDED_ACTIONS, 0)]:
            del self.states[key]
        return state


class StandstillWait:
    """An instant action that is FINISHED once the robot stands (cancelOrder, startPause:
    RUNNING while it brakes), or ``limit_s`` after it began if its standing is never seen
    (its pose no longer arriving).

    Attributes:
        action: the action waiting, or None.
        order_id: the order in hand when it began.
    """

    def __init__(self, limit_s: float) -> None:
        self.limit_s = limit_s
        self.action: ActionState | None = None
        self.order_id = ""
        self._by = float("inf")

    def begin(self, action: ActionState, now: float, order_id: str) -> None:
        """``action`` waits from ``now`` [s]; RUNNING meanwhile."""
        action.status = "RUNNING"
        self.action, self.order_id, self._by = action, order_id, now + self.limit_s

    def due(self, standing: bool, now: float) -> bool:
        """Whether an action waits and may end now."""
        return self.action is not None and (standing or now >= self._by)

    def end(self) -> bool:
        """FINISHED, if one waits; True if one did."""
        if self.action is None:
            return False
        self.action.status, self.action = "FINISHED", None
        return True
