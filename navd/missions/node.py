"""The missions module: runs one mission at a time through the planner's goals.

A mission request replaces the running mission (its goal is cancelled). Goals, their
statuses, the pose and a person's commands go through the bus like everyone else's, so a
mission drives through the same planner and safety gate as a goal sent by hand.
"""

from __future__ import annotations

from navd.geometry import Pose2
from navd.lifecycle import Module, ModuleContext
from navd.lifecycle.messages import (
    BeaconPlaces,
    GoalStatus,
    Message,
    MissionCommand,
    MissionRequest,
    MissionStatus,
    PoseEstimate,
)
from navd.missions.executor import MissionExecutor, no_mission
from navd.missions.settings import MissionSettings

__all__ = ["TICK_S", "MissionNode"]

TICK_S = 0.1  # [s] how often a wait step looks at the clock


class MissionNode(Module):
    """Runs missions (see the module docstring)."""

    def __init__(self) -> None:
        super().__init__("missions")
        self.mission: MissionExecutor | None = None
        self._runs = 0
        self._pose: Pose2 | None = None
        self._places: dict[str, tuple[float, float]] = {}  # [m] beacons' places by id

    async def on_configure(self, ctx: ModuleContext) -> None:
        self.ctx = ctx
        # the config's beacons (they need a restart), before the estimator publishes them with
        # the learnt ones
        self.settings = ctx.settings(MissionSettings.from_config)
        self._places = self.settings.value.places()
        ctx.subscribe(MissionRequest, self._on_request)
        ctx.subscribe(MissionCommand, self._on_command)
        ctx.subscribe(GoalStatus, self._on_goal_status)
        ctx.subscribe(PoseEstimate, self._on_pose)
        ctx.subscribe(BeaconPlaces, self._on_beacons)

    async def on_activate(self) -> None:
        self.ctx.every(TICK_S, self._tick, name="mission-clock")

    async def on_deactivate(self) -> None:
        mission = self.mission
        if mission is not None and not mission.ended:
            now, why = self.ctx.clock.now(), "cancelled: navd is stopping"
            self._publish(mission.command("cancel", now, self._pose, by=why)[0])

    def settings_in_use(self) -> tuple[object, ...]:
        return (self.settings.value,)

    def _publish(self, messages: list[Message]) -> None:
        for message in messages:
            if isinstance(message, MissionStatus) and message.info.event != "progress":
                info = message.info
                self.ctx.log.info(
                    "mission",
                    mission_id=info.mission_id,
                    what=info.event,
                    state=info.state,
                    step=info.step,
                    steps=info.steps,
                    round=info.round,
                    reason=info.reason or None,
                )
            self.ctx.publish(message)

    def _on_pose(self, pose: PoseEstimate) -> None:
        self._pose = Pose2(pose.x_m, pose.y_m, pose.yaw_rad)

    def _on_beacons(self, places: BeaconPlaces) -> None:
        self._places = {p.beacon_id: (p.x_m, p.y_m) for p in places.places}
        if self.mission is not None:
            self.mission.places = self._places

    def _on_request(self, request: MissionRequest) -> None:
        now = self.ctx.clock.now()
        old = self.mission
        if old is not None and not old.ended:
            why = f"replaced by mission {request.mission_id}"
            self._publish(old.command("cancel", now, self._pose, by=why)[0])
        self._runs += 1
        self.mission = MissionExecutor(request, self._runs)
        self.mission.places = self._places
        self._publish(self.mission.start(now, self._pose))

    def _on_command(self, command: MissionCommand) -> None:
        now = self.ctx.clock.now()
        mission = self.mission
        if mission is None:
            refusal = "no mission has been run"
            messages: list[Message] = [no_mission(now, f"{command.action}: {refusal}")]
        else:
            messages, refusal = mission.command(command.action, now, self._pose)
            if refusal:
                messages = [mission.refused(now, f"{command.action}: {refusal}")]
        if refusal:
            self.ctx.log.warning("mission_command_refused", action=command.action, reason=refusal)
        self._publish(messages)

    def _on_goal_status(self, status: GoalStatus) -> None:
        mission = self.mission
        if mission is not None:
            self._publish(mission.on_goal_status(status, self.ctx.clock.now(), self._pose))

    def _tick(self, now: float) -> None:
        mission = self.mission
        if mission is not None:
            self._publish(mission.on_tick(now, self._pose))
