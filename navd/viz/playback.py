"""Replaying a recording through the whole pipeline, and where it differs from the original.

The daemon runs here, in this process, on simulated time, with the modules the recorded
config gives it except its edges (the TCP server, the chassis, the live view, the recorder):
the recorded inputs take their place. Each input is put on the bus at its recorded arrival
time (shifted so the replay starts at ``START_S``), after the clock has moved there one
timer at a time and the work due has finished (the lockstep of ``navd.lifecycle.lockstep``),
so estimation, SLAM and planning run as an infinitely fast computer would. The outputs are
kept and compared with the recorded ones: poses at the recorded instants, the map (IoU of
occupied cells), the last route of each goal, the goals' final states, the wheel commands.

Maps go to a folder of the replay's own, never the robot's.
"""

from __future__ import annotations

import asyncio
import bisect
import dataclasses
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from navd.config import NavdConfig
from navd.lifecycle.clock import SimClock
from navd.lifecycle.daemon import Daemon
from navd.lifecycle.lockstep import Lockstep
from navd.lifecycle.messages import (
    DriveCommand,
    GoalStatus,
    MapUpdate,
    Message,
    PoseEstimate,
)
from navd.lifecycle.messages import (
    Path as Route,
)
from navd.lifecycle.module import Module
from navd.viz.record_codec import OUTPUTS
from navd.viz.recording_reader import Recording, RecordingError

__all__ = ["EDGE_MODULES", "PlaybackReport", "map_iou", "play", "replay_config"]

START_S = 1.0  # [s] simulated time of the first input
AFTER_S = 2.0  # [s] the replay runs on this long past the last input
EDGE_MODULES = frozenset({"tcp", "chassis", "viz", "recorder"})  # their inputs are recorded
STEP_TIMEOUT_S = 600.0  # [s] real time a step may wait for start-up work (kernels compiling)
OCCUPIED = 50  # a cell above this [% occupied] is an obstacle when maps are compared


def replay_config(recorded: dict[str, Any], maps: Path) -> NavdConfig:
    """The recorded config, run on simulated time without its edges, saving maps to
    ``maps``."""
    plain = {k: dict(v) if isinstance(v, dict) else v for k, v in recorded.items()}
    plain["tcp"] = {}  # not run; its recorded host may need the token that was not recorded
    plain["viz"] = {"enabled": False}
    plain["record"] = {"enabled": False}
    plain["chassis"] = {**plain.get("chassis", {}), "enabled": False}
    plain["lifecycle"] = {**plain.get("lifecycle", {}), "clock": "simulated"}
    plain["slam"] = {**plain.get("slam", {}), "map_dir": str(maps)}
    # the replayed daemon's own log: what went wrong, not every step (it repeats a past run)
    plain["logging"] = {**plain.get("logging", {}), "level": "warning"}
    return NavdConfig.model_validate(plain)


def map_iou(a: MapUpdate, b: MapUpdate) -> float:
    """Intersection over union of the occupied cells of two maps, placed by their origins
    (same resolution; 1.0 when neither has any)."""
    if not math.isclose(a.resolution_m, b.resolution_m):
        return 0.0
    res = a.resolution_m

    def cells(update: MapUpdate) -> set[tuple[int, int]]:
        rows, cols = np.nonzero(np.asarray(update.occupancy) > OCCUPIED)
        dx = round(update.origin_x_m / res)
        dy = round(update.origin_y_m / res)
        return set(zip((rows + dy).tolist(), (cols + dx).tolist(), strict=True))

    first, second = cells(a), cells(b)
    union = first | second
    return 1.0 if not union else len(first & second) / len(union)


@dataclass
class PlaybackReport:
    """What the replay gave against what was recorded (times in the replay's clock [s]).

    Attributes:
        inputs: input messages replayed.
        duration_s: [s] of recorded time replayed.
        outputs: per output type, (recorded, replayed) counts.
        pose_error_m: median and max distance between the replayed pose and the recorded
            one at each recorded pose's time (None without poses).
        map_iou: occupied-cell IoU of the last recorded map and the replayed map of that
            time (None without a map).
        routes: per goal, the recorded and replayed last routes' lengths [m] and the largest
            distance from a point of either to the other [m].
        goals: per goal, the recorded and replayed final states.
        wheel_difference_mps: median and max |difference| of the linear wheel command at
            the recorded commands' times.
        cut_short: files that ended mid-way.
        differences: what differs, in words (empty when nothing notable).
    """

    inputs: int = 0
    duration_s: float = 0.0
    outputs: dict[str, tuple[int, int]] = field(default_factory=dict)
    pose_error_m: tuple[float, float] | None = None
    map_iou: float | None = None
    routes: dict[str, dict[str, float]] = field(default_factory=dict)
    goals: dict[str, tuple[str, str]] = field(default_factory=dict)
    wheel_difference_mps: tuple[float, float] | None = None
    cut_short: list[str] = field(default_factory=list)
    differences: list[str] = field(default_factory=list)

    def as_dict(self) -> dict[str, Any]:
        """The report as JSON can hold it."""
        return dataclasses.asdict(self)


def _shifted(message: Message, shift_s: float) -> Message:
    return dataclasses.replace(
        message, stamp=message.stamp + shift_s, received=message.received + shift_s
    )


async def play(
    recording: Recording, build: Callable[[NavdConfig], Sequence[Module]], work_dir: Path
) -> PlaybackReport:
    """Replay ``recording`` with the modules ``build`` makes of its config, and compare.

    Raises:
        ConfigError: the recorded config is not valid for this navd.
        RecordingError: the recording holds no inputs.
    """
    assert recording.config is not None
    inputs = [(t, m) for t, m in recording.messages if t.startswith("/navd/in/")]
    if not inputs:
        raise RecordingError("the recording holds no inputs to replay")
    config = replay_config(recording.config, work_dir / "maps")
    modules = [m for m in build(config) if m.name not in EDGE_MODULES]
    daemon = Daemon(config, modules, handle_signals=False)
    replayed: dict[type[Message], list[Message]] = {kind: [] for kind in OUTPUTS}
    replaying = True  # what the daemon says once it is told to stop is not the replay's

    def keep(message: Message) -> None:
        if replaying:
            replayed[type(message)].append(message)

    for kind in OUTPUTS:
        daemon.bus.subscribe(kind, keep, module="playback")
    shift = START_S - inputs[0][1].received
    task = asyncio.create_task(daemon.run())
    try:
        await asyncio.wait_for(daemon.ready.wait(), STEP_TIMEOUT_S)
        assert isinstance(daemon.clock, SimClock)  # replay_config asks for simulated time
        lockstep = Lockstep(daemon.clock, daemon.workers, daemon.traffic)
        for _, message in inputs:
            moved = _shifted(message, shift)
            if moved.received > daemon.clock.now():
                await lockstep.step_to(moved.received, {}, STEP_TIMEOUT_S)
            daemon.bus.publish(moved)
        end = inputs[-1][1].received + shift + AFTER_S
        await lockstep.step_to(end, {}, STEP_TIMEOUT_S)
    finally:
        replaying = False
        daemon.request_shutdown("replay over")
        await asyncio.wait_for(task, 60.0)
    recorded: dict[type[Message], list[Message]] = {kind: [] for kind in OUTPUTS}
    for topic, message in recording.messages:
        if topic.startswith("/navd/out/"):
            recorded[type(message)].append(_shifted(message, shift))
    report = _compare(recorded, replayed)
    report.inputs = len(inputs)
    report.duration_s = round(inputs[-1][1].received - inputs[0][1].received, 3)
    report.cut_short = [str(p) for p in recording.cut_short]
    return report


def _at(times: npt.NDArray[np.float64], t: float) -> int:
    """The index of the last time at or before ``t`` (0 when none)."""
    return max(bisect.bisect_right(times.tolist(), t) - 1, 0)


def _compare(
    recorded: dict[type[Message], list[Message]], replayed: dict[type[Message], list[Message]]
) -> PlaybackReport:
    report = PlaybackReport(
        outputs={k.__name__: (len(recorded[k]), len(replayed[k])) for k in recorded}
    )
    _compare_poses(recorded[PoseEstimate], replayed[PoseEstimate], report)
    _compare_maps(recorded[MapUpdate], replayed[MapUpdate], report)
    _compare_routes(recorded[Route], replayed[Route], report)
    _compare_goals(recorded[GoalStatus], replayed[GoalStatus], report)
    _compare_wheels(recorded[DriveCommand], replayed[DriveCommand], report)
    return report


def _compare_poses(mine: list[Message], theirs: list[Message], report: PlaybackReport) -> None:
    if not mine or not theirs:
        if mine or theirs:
            report.differences.append(f"poses: {len(mine)} recorded, {len(theirs)} replayed")
        return
    times = np.array([p.received for p in theirs])
    errors = []
    for pose in mine:
        assert isinstance(pose, PoseEstimate)
        other = theirs[_at(times, pose.received)]
        assert isinstance(other, PoseEstimate)
        errors.append(math.hypot(pose.x_m - other.x_m, pose.y_m - other.y_m))
    report.pose_error_m = (round(float(np.median(errors)), 4), round(float(np.max(errors)), 4))
    if report.pose_error_m[1] > 0.1:
        report.differences.append(
            f"poses: up to {report.pose_error_m[1]:.3f} m apart "
            f"(median {report.pose_error_m[0]:.3f} m)"
        )


def _compare_maps(mine: list[Message], theirs: list[Message], report: PlaybackReport) -> None:
    if not mine:
        return
    last = mine[-1]
    assert isinstance(last, MapUpdate)
    earlier = [m for m in theirs if m.stamp <= last.stamp + 1e-6]
    if not earlier:
        report.differences.append("map: the replay built none by the last recorded map's time")
        report.map_iou = 0.0
        return
    other = earlier[-1]
    assert isinstance(other, MapUpdate)
    report.map_iou = round(map_iou(last, other), 4)
    if report.map_iou < 0.95:
        report.differences.append(f"map: occupied cells agree at IoU {report.map_iou:.3f}")


def _length(points: npt.NDArray[np.float64]) -> float:
    return float(np.hypot(*np.diff(points, axis=0).T).sum()) if len(points) > 1 else 0.0


def _apart(a: npt.NDArray[np.float64], b: npt.NDArray[np.float64]) -> float:
    """[m] the largest distance from a point of either route to the nearest of the other."""
    d = np.hypot(a[:, None, 0] - b[None, :, 0], a[:, None, 1] - b[None, :, 1])
    return float(max(d.min(axis=1).max(), d.min(axis=0).max()))


def _compare_routes(mine: list[Message], theirs: list[Message], report: PlaybackReport) -> None:
    def last_routes(routes: list[Message]) -> dict[str, npt.NDArray[np.float64]]:
        kept: dict[str, npt.NDArray[np.float64]] = {}
        for route in routes:
            assert isinstance(route, Route)
            kept[route.goal_id] = np.asarray(route.points_m, dtype=np.float64).reshape(-1, 2)
        return kept

    recorded, replayed = last_routes(mine), last_routes(theirs)
    for goal_id, points in recorded.items():
        other = replayed.get(goal_id)
        if other is None or not len(other) or not len(points):
            report.differences.append(f"route of {goal_id!r}: not planned in the replay")
            continue
        apart = _apart(points, other)
        report.routes[goal_id] = {
            "recorded_length_m": round(_length(points), 3),
            "replayed_length_m": round(_length(other), 3),
            "apart_m": round(apart, 3),
        }
        if apart > 0.25:
            report.differences.append(f"route of {goal_id!r}: up to {apart:.2f} m apart")


def _compare_goals(mine: list[Message], theirs: list[Message], report: PlaybackReport) -> None:
    def finals(statuses: list[Message]) -> dict[str, str]:
        states: dict[str, str] = {}
        for status in statuses:
            assert isinstance(status, GoalStatus)
            states[status.goal_id] = status.state
        return states

    recorded, replayed = finals(mine), finals(theirs)
    for goal_id, state in recorded.items():
        other = replayed.get(goal_id, "never heard of")
        report.goals[goal_id] = (state, other)
        if other != state:
            report.differences.append(f"goal {goal_id!r}: {state} when recorded, {other} replayed")


def _compare_wheels(mine: list[Message], theirs: list[Message], report: PlaybackReport) -> None:
    if not mine or not theirs:
        return
    times = np.array([c.stamp for c in theirs])
    gaps = []
    for command in mine:
        assert isinstance(command, DriveCommand)
        other = theirs[_at(times, command.stamp)]
        assert isinstance(other, DriveCommand)
        gaps.append(abs(command.linear_mps - other.linear_mps))
    report.wheel_difference_mps = (round(float(np.median(gaps)), 4), round(float(max(gaps)), 4))
