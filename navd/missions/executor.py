"""One mission's state machine: which step runs, what it asked the planner, what comes next.

It knows nothing of the bus: each input (a goal's status, the clock, a person's command)
returns the messages to publish. A driving step sends a goal named after the mission, the
round, the step and the attempt, and waits for that goal's end; a wait step waits on the
clock; a pause step waits for "continue". A failed step follows its policy: skipped, retried
(a fresh goal) up to its retries, or the mission aborted. Pausing cancels the step's goal;
resuming sends it again. A goal of the mission's that someone else cancels (a person's new
goal) pauses the mission rather than failing the step.

Beacon steps are driven as a list of waypoints (``waypoints.py``) worked out when the step
starts, from the beacons' places as the estimator last published them. A beacon with no
place fails the step, which then follows its policy.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass

from navd.geometry import Pose2
from navd.lifecycle.messages import (
    BEACON_STEPS,
    CancelGoal,
    GeoGoal,
    Goal,
    GoalStatus,
    Message,
    MissionRequest,
    MissionStatus,
    MissionStep,
)
from navd.missions.errors import UnknownBeaconError
from navd.missions.waypoints import Waypoint, approach_pose, beacon_waypoints, waypoint_pose
from navd.wire import MissionInfo

__all__ = ["MissionExecutor", "no_mission"]

ENDED = ("completed", "failed", "canceled")


def no_mission(now: float, reason: str) -> MissionStatus:
    """The status that answers a command when no mission has been run."""
    info = MissionInfo(
        mission_id="", name="", state="none", step=0, steps=0, round=0, rounds=0,
        event="refused", reason=reason,
    )  # fmt: skip
    return MissionStatus(stamp=now, received=now, info=info)


@dataclass
class _Leg:
    """The goal a driving step has out: its id, and whether it is an approach's slow part."""

    goal_id: str
    final: bool


class MissionExecutor:
    """Runs ``request`` (see the module docstring)."""

    def __init__(self, request: MissionRequest, run: int = 1) -> None:
        self.request = request
        self.run = run  # this daemon's count of missions: goal ids never repeat across runs
        self.legs = 0  # goals sent so far: a retried or resumed step's goal is a new one
        self.state = "running"
        self.index = -1  # the step being run, from 0
        self.round = 1
        self.attempt = 0
        self.done = 0
        self.failed = 0
        self._done_this_round = 0
        self.leg: _Leg | None = None
        self.wait_until = math.inf
        self.distance_m = math.nan
        self.eta_s = math.nan
        self.reason = ""
        self._approach_from: Pose2 | None = None
        # [m] beacon places by id, as last published (the node keeps it current)
        self.places: Mapping[str, tuple[float, float]] = {}
        self._waypoints: list[Waypoint] = []  # a beacon step's, the current one first

    @property
    def ended(self) -> bool:
        return self.state in ENDED

    @property
    def step(self) -> MissionStep | None:
        steps = self.request.steps
        return steps[self.index] if 0 <= self.index < len(steps) else None

    # --- inputs -------------------------------------------------------------------------

    def start(self, now: float, pose: Pose2 | None) -> list[Message]:
        """Begin with the first step."""
        return [self._status(now, "started"), *self._next(now, pose)]

    def on_goal_status(self, status: GoalStatus, now: float, pose: Pose2 | None) -> list[Message]:
        """A goal's progress or end; only the step's own goal counts."""
        leg = self.leg
        if leg is None or status.goal_id != leg.goal_id or self.state != "running":
            return []
        if status.state in ("active", "paused"):
            self.distance_m, self.eta_s = status.distance_remaining_m, status.eta_s
            return [self._status(now, "progress")]
        self.leg = None
        if status.state == "reached":
            step = self.step
            if step is not None and step.kind == "approach" and not leg.final:
                return self._drive(now, pose, final=True)  # the slow part
            if step is not None and step.kind in BEACON_STEPS and len(self._waypoints) > 1:
                self._waypoints.pop(0)
                return self._drive(now, pose, final=False)
            return self._step_done(now, pose)
        if status.state == "canceled":
            # someone else's goal replaced the step's: hold the mission until resumed
            self.state = "paused"
            self.reason = status.reason or "its goal was cancelled"
            return [self._status(now, "paused")]
        return self._step_failed(now, pose, status.reason or "the goal failed")

    def on_tick(self, now: float, pose: Pose2 | None) -> list[Message]:
        """The clock moved: a wait step may be over."""
        if self.state == "running" and now >= self.wait_until:
            self.wait_until = math.inf
            return self._step_done(now, pose)
        return []

    def command(
        self, action: str, now: float, pose: Pose2 | None, *, by: str = "cancelled by a person"
    ) -> tuple[list[Message], str]:
        """A person's pause, resume, cancel or continue; the messages, and why it does
        nothing (empty when it did something). ``by``: who cancels, as the reason says."""
        if self.ended:
            return [], f"mission {self.request.mission_id} has ended ({self.state})"
        if action == "cancel":
            out = self._cancel_leg(now)
            self.state, self.reason = "canceled", by
            return [*out, self._status(now, "canceled")], ""
        if action == "pause":
            if self.state != "running":
                return [], f"mission is {self.state}, not running"
            out = self._cancel_leg(now)
            self.state = "paused"
            return [*out, self._status(now, "paused")], ""
        if action == "resume":
            if self.state != "paused":
                return [], f"mission is {self.state}, not paused"
            self.state, self.reason = "running", ""
            return [self._status(now, "resumed"), *self._restart_step(now, pose)], ""
        if action == "continue":
            if self.state != "waiting":
                return [], f"mission is {self.state}: no step waits for continue"
            self.state = "running"
            return self._step_done(now, pose), ""
        return [], f"unknown action {action!r}"

    # --- steps --------------------------------------------------------------------------

    def _next(self, now: float, pose: Pose2 | None) -> list[Message]:
        """Go on to the next step (the next round after the last)."""
        self.index += 1
        if self.index >= len(self.request.steps):
            rounds = self.request.rounds
            if rounds and self.round >= rounds:
                self.state = "completed"
                self.index = len(self.request.steps) - 1
                return [self._status(now, "completed")]
            if self._done_this_round == 0:
                # every step of a round failed: another round would only fail again, at once
                self.state = "failed"
                self.index = len(self.request.steps) - 1
                self.reason = f"every step of round {self.round} failed; last: {self.reason}"
                return [self._status(now, "failed")]
            self.round += 1
            self.index = 0
            self._done_this_round = 0
        self.attempt = 0
        return self._begin(now, pose)

    def _begin(self, now: float, pose: Pose2 | None) -> list[Message]:
        step = self.step
        assert step is not None
        self.distance_m = self.eta_s = math.nan
        out: list[Message] = [self._status(now, "step_started")]
        if step.kind == "wait":
            self.wait_until = now + step.seconds
            return out
        if step.kind == "pause":
            self.state = "waiting"
            return [*out, self._status(now, "waiting")]
        self._approach_from = pose
        if step.kind in BEACON_STEPS:
            try:
                self._waypoints = beacon_waypoints(step, self.places, pose)
            except UnknownBeaconError as err:
                return [*out, *self._step_failed(now, pose, str(err.args[0]))]
        return [*out, *self._drive(now, pose, final=False)]

    def _restart_step(self, now: float, pose: Pose2 | None) -> list[Message]:
        """Run the current step again from its start (after a pause)."""
        step = self.step
        if step is None:
            return self._next(now, pose)
        if step.kind == "wait":
            self.wait_until = now + step.seconds
            return []
        if step.kind == "pause":
            self.state = "waiting"
            return [self._status(now, "waiting")]
        return self._drive(now, pose, final=False)

    def _drive(self, now: float, pose: Pose2 | None, *, final: bool) -> list[Message]:
        step = self.step
        assert step is not None
        suffix = "b" if final else "a"
        self.legs += 1
        goal_id = (
            f"{self.request.mission_id}:{self.run}.{self.round}.{self.index + 1}."
            f"{self.legs}{suffix}"
        )
        self.leg = _Leg(goal_id, final or step.kind != "approach")
        if step.kind == "goto_gps":
            return [
                GeoGoal(
                    stamp=now,
                    received=now,
                    goal_id=goal_id,
                    latitude_deg=step.latitude_deg,
                    longitude_deg=step.longitude_deg,
                    yaw_rad=step.yaw_rad,
                )
            ]
        x, y, yaw, speed = step.x_m, step.y_m, step.yaw_rad, step.speed_mps
        if step.kind in BEACON_STEPS:
            x, y, yaw = waypoint_pose(self._waypoints[0], pose)
        elif step.kind == "approach":
            x, y, yaw = approach_pose(step, self._approach_from or pose, final=final)
            if not final:
                speed = None  # the way there at the robot's own speed
        return [
            Goal(
                stamp=now,
                received=now,
                goal_id=goal_id,
                x_m=x,
                y_m=y,
                yaw_rad=yaw,
                max_speed_mps=speed,
            )
        ]

    def _step_done(self, now: float, pose: Pose2 | None) -> list[Message]:
        self.done += 1
        self._done_this_round += 1
        self.reason = ""  # an earlier step's failure is not this one's
        return [self._status(now, "step_done"), *self._next(now, pose)]

    def _step_failed(self, now: float, pose: Pose2 | None, reason: str) -> list[Message]:
        step = self.step
        assert step is not None
        self.reason = reason
        if step.on_failure == "retry" and self.attempt < step.retries:
            self.attempt += 1
            return [self._status(now, "step_retried"), *self._drive(now, pose, final=False)]
        self.failed += 1
        if step.on_failure == "skip":
            return [self._status(now, "step_skipped"), *self._next(now, pose)]
        self.state = "failed"
        return [self._status(now, "step_failed"), self._status(now, "failed")]

    def _cancel_leg(self, now: float) -> list[Message]:
        self.wait_until = math.inf
        if self.leg is None:
            return []
        goal_id, self.leg = self.leg.goal_id, None
        return [CancelGoal(stamp=now, received=now, goal_id=goal_id)]

    def refused(self, now: float, reason: str) -> MissionStatus:
        """The status that answers a command that did nothing, saying why."""
        status = self._status(now, "refused")
        info = status.info.model_copy(update={"reason": reason})
        return dataclasses.replace(status, info=info)

    def _status(self, now: float, event: str) -> MissionStatus:
        request, step = self.request, self.step
        info = MissionInfo(
            mission_id=request.mission_id,
            name=request.name,
            state=self.state,
            step=self.index + 1,
            steps=len(request.steps),
            round=self.round,
            rounds=request.rounds,
            kind="" if step is None else step.kind,
            event=event,
            distance_m=_known(self.distance_m),
            eta_s=_known(self.eta_s),
            message=step.message if step is not None and step.kind == "pause" else "",
            reason=self.reason,
            done=self.done,
            failed=self.failed,
        )
        return MissionStatus(stamp=now, received=now, info=info)


def _known(value: float) -> float | None:
    """A number as the mission's progress gives it: None when unknown (NaN)."""
    return None if math.isnan(value) else value
