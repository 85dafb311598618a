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
import dataclasses
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
from pydantic import ValidationError

from navd import __version__
from navd.config import NavdConfig
from navd.lifecycle import Daemon, Lockstep, Module, SimClock
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
from navd.viz.errors import RecordingError
from navd.viz.record_codec import OUTPUTS
from navd.viz.recording_reader import Recording

__all__ = ["EDGE_MODULES", "PlaybackReport", "map_iou", "play", "replay_config"]

START_S = 1.0  # [s] simulated time of the first input
AFTER_S = 2.0  # [s] the replay runs on this long past the last input
EDGE_MODULES = frozenset({"tcp", "chassis", "viz", "recorder"})  # their inputs are recorded
STEP_TIMEOUT_S = 600.0  # [s] real time a step may wait for start-up work (kernels compiling)
OCCUPIED = 50  # a cell above this [% occupied] is an obstacle when maps are compared


def replay_config(recorded: dict[str, Any], maps: Path) -> NavdConfig:
    """The recorded config, run on simulated time without its edges, saving maps to
    ``maps``.

    Raises:
        RecordingError: the recorded config does not suit this navd (a key it does not know,
            from another version), naming the keys.
    """
    try:
        return NavdConfig.model_validate(_replayable(recorded, maps))
    except (ValidationError, TypeError, AttributeError) as err:
        raise RecordingError(
            f"the recorded config does not suit this navd {__version__} (was it recorded by "
            f"another version?): {err}"
        ) from err


def _replayable(recorded: dict[str, Any], maps: Path) -> dict[str, Any]:
    plain = {k: dict(v) if isinstance(v, dict) else v for k, v in recorded.items()}
    plain["tcp"] = {}  # not run; its recorded host may need the token that was not recorded
    plain["viz"] = {"enabled": False}
    plain["record"] = {"enabled": False}
    plain["chassis"] = {**plain.get("chassis", {}), "enabled": False}
    plain["lifecycle"] = {**plain.get("lifecycle", {}), "clock": "simulated"}
    plain["slam"] = {**plain.get("slam", {}), "map_dir": str(maps)}
    # the replayed daemon's own log: what went wrong, not every step (it repeats a past run)
    plain["logging"] = {**plain.get("logging", {}), "level": "warning"}
    return plain


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


class _Outputs:
    """What a run decided, kept compactly as it streams past (a long recording is never
    held whole): pose and wheel-command tracks, the last route of each goal, each goal's
    last state, and the last map."""

    def __init__(self) -> None:
        self.counts: dict[str, int] = {kind.__name__: 0 for kind in OUTPUTS}
        self._poses: list[tuple[float, float, float]] = []  # [s, m, m]
        self._wheels: list[tuple[float, float]] = []  # [s, m/s]
        self.routes: dict[str, npt.NDArray[np.float64]] = {}
        self.goals: dict[str, str] = {}
        self.map: MapUpdate | None = None

    def add(self, message: Message, shift_s: float = 0.0) -> None:
        self.counts[type(message).__name__] += 1
        t = message.received + shift_s
        if isinstance(message, PoseEstimate):
            self._poses.append((t, message.x_m, message.y_m))
        elif isinstance(message, DriveCommand):
            self._wheels.append((message.stamp + shift_s, message.linear_mps))
        elif isinstance(message, Route):
            self.routes[message.goal_id] = np.asarray(message.points_m, dtype=np.float64)
        elif isinstance(message, GoalStatus):
            self.goals[message.goal_id] = message.state
        elif isinstance(message, MapUpdate):
            self.map = message

    @property
    def poses(self) -> npt.NDArray[np.float64]:
        """N x 3: time [s], x [m], y [m]."""
        return np.array(self._poses, dtype=np.float64).reshape(-1, 3)

    @property
    def wheels(self) -> npt.NDArray[np.float64]:
        """N x 2: time [s], linear command [m/s]."""
        return np.array(self._wheels, dtype=np.float64).reshape(-1, 2)


def _shifted(message: Message, shift_s: float) -> Message:
    return dataclasses.replace(
        message, stamp=message.stamp + shift_s, received=message.received + shift_s
    )


class _Feed:
    """Puts a recording's inputs on a daemon's bus at their instants, and keeps the
    recorded outputs beside the replayed ones."""

    def __init__(self, daemon: Daemon, lockstep: Lockstep, replayed: _Outputs) -> None:
        self.daemon = daemon
        self.lockstep = lockstep
        self.replayed = replayed
        self.recorded = _Outputs()
        self.early: list[Message] = []  # outputs before the first input: shifted once known
        self.shift: float | None = None  # [s] replay time minus recorded time
        self.first = self.last = 0.0  # [s] recorded times of the first and last inputs
        self.inputs = 0
        # The last recorded map, and the replay's map when the recording reached it (the
        # replay keeps pace with the recording's inputs).
        self.maps: tuple[MapUpdate, MapUpdate | None] | None = None

    async def take(self, topic: str, message: Message) -> None:
        if topic.startswith("/navd/out/"):
            if isinstance(message, MapUpdate):
                self.maps = (message, self.replayed.map)
            if self.shift is None:
                self.early.append(message)
            else:
                self.recorded.add(message, self.shift)
            return
        if not topic.startswith("/navd/in/"):
            return
        if self.shift is None:
            self.shift = START_S - message.received
            self.first = message.received
            for early in self.early:
                self.recorded.add(early, self.shift)
            self.early.clear()
        moved = _shifted(message, self.shift)
        if moved.received > self.daemon.clock.now():
            await self.lockstep.step_to(moved.received, {}, STEP_TIMEOUT_S)
        self.daemon.bus.publish(moved)
        self.inputs += 1
        self.last = message.received

    async def finish(self) -> None:
        """Run on past the last input (the work it started ends)."""
        if self.shift is None:
            raise RecordingError("the recording holds no inputs to replay")
        await self.lockstep.step_to(self.last + self.shift + AFTER_S, {}, STEP_TIMEOUT_S)


async def play(
    recording: Recording, build: Callable[[NavdConfig], Sequence[Module]], work_dir: Path
) -> PlaybackReport:
    """Replay ``recording`` with the modules ``build`` makes of its config, and compare.

    The recording is read once, as it streams: each input goes to the daemon at its
    instant; each recorded output is kept (compactly) for the comparison.

    Raises:
        RecordingError: the recorded config does not suit this navd, or the recording holds
            no inputs.
    """
    config = replay_config(recording.config, work_dir / "maps")
    modules = [m for m in build(config) if m.name not in EDGE_MODULES]
    daemon = Daemon(config, modules, handle_signals=False)
    replayed = _Outputs()
    replaying = True  # what the daemon says once it is told to stop is not the replay's

    def keep(message: Message) -> None:
        if replaying:
            replayed.add(message)

    for kind in OUTPUTS:
        daemon.bus.subscribe(kind, keep, module="playback")
    task = asyncio.create_task(daemon.run())
    try:
        await asyncio.wait_for(daemon.ready.wait(), STEP_TIMEOUT_S)
        assert isinstance(daemon.clock, SimClock)  # replay_config asks for simulated time
        feed = _Feed(daemon, Lockstep(daemon.clock, daemon.workers, daemon.line_counts), replayed)
        for topic, message in recording.messages():
            await feed.take(topic, message)
        await feed.finish()
    finally:
        replaying = False
        daemon.request_shutdown("replay over")
        await asyncio.wait_for(task, 60.0)
    report = _compare(feed.recorded, replayed, feed.maps)
    report.inputs = feed.inputs
    report.duration_s = round(feed.last - feed.first, 3)
    report.cut_short = [str(p) for p in recording.cut_short]
    header = recording.header
    if header.get("had_map") or header.get("seeded_pose"):
        report.differences.insert(
            0,
            f"the recording began {header.get('into_run_s', '?')} s into the daemon's run: "
            "the replay starts from the pose the robot had then"
            + (", without the map the daemon had built" if header.get("had_map") else ""),
        )
    return report


def _at(times: npt.NDArray[np.float64], t: npt.NDArray[np.float64]) -> npt.NDArray[np.intp]:
    """For each of ``t``, the index of the last of ``times`` at or before it (0 when none)."""
    found: npt.NDArray[np.intp] = np.searchsorted(times, t, side="right") - 1
    return np.maximum(found, 0)


def _compare(
    recorded: _Outputs,
    replayed: _Outputs,
    maps: tuple[MapUpdate, MapUpdate | None] | None,
) -> PlaybackReport:
    report = PlaybackReport(
        outputs={k: (recorded.counts[k], replayed.counts[k]) for k in recorded.counts}
    )
    _compare_poses(recorded.poses, replayed.poses, report)
    if maps is not None:
        _compare_maps(*maps, report)
    _compare_routes(recorded.routes, replayed.routes, report)
    _compare_goals(recorded.goals, replayed.goals, report)
    _compare_wheels(recorded.wheels, replayed.wheels, report)
    return report


def _compare_poses(
    mine: npt.NDArray[np.float64], theirs: npt.NDArray[np.float64], report: PlaybackReport
) -> None:
    if not len(mine) or not len(theirs):
        if len(mine) or len(theirs):
            report.differences.append(f"poses: {len(mine)} recorded, {len(theirs)} replayed")
        return
    other = theirs[_at(theirs[:, 0], mine[:, 0])]
    errors = np.hypot(mine[:, 1] - other[:, 1], mine[:, 2] - other[:, 2])
    report.pose_error_m = (round(float(np.median(errors)), 4), round(float(errors.max()), 4))
    if report.pose_error_m[1] > 0.1:
        report.differences.append(
            f"poses: up to {report.pose_error_m[1]:.3f} m apart "
            f"(median {report.pose_error_m[0]:.3f} m)"
        )


def _compare_maps(mine: MapUpdate, other: MapUpdate | None, report: PlaybackReport) -> None:
    if other is None:
        report.differences.append("map: the replay built none by the last recorded map's time")
        report.map_iou = 0.0
        return
    report.map_iou = round(map_iou(mine, other), 4)
    if report.map_iou < 0.95:
        report.differences.append(f"map: occupied cells agree at IoU {report.map_iou:.3f}")


def _length(points: npt.NDArray[np.float64]) -> float:
    return float(np.hypot(*np.diff(points, axis=0).T).sum()) if len(points) > 1 else 0.0


def _apart(a: npt.NDArray[np.float64], b: npt.NDArray[np.float64]) -> float:
    """[m] the largest distance from a point of either route to the nearest of the other."""
    d = np.hypot(a[:, None, 0] - b[None, :, 0], a[:, None, 1] - b[None, :, 1])
    return float(max(d.min(axis=1).max(), d.min(axis=0).max()))


def _compare_routes(
    mine: dict[str, npt.NDArray[np.float64]],
    theirs: dict[str, npt.NDArray[np.float64]],
    report: PlaybackReport,
) -> None:
    for goal_id, points in mine.items():
        other = theirs.get(goal_id)
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


def _compare_goals(mine: dict[str, str], theirs: dict[str, str], report: PlaybackReport) -> None:
    for goal_id, state in mine.items():
        other = theirs.get(goal_id, "never heard of")
        report.goals[goal_id] = (state, other)
        if other != state:
            report.differences.append(f"goal {goal_id!r}: {state} when recorded, {other} replayed")


def _compare_wheels(
    mine: npt.NDArray[np.float64], theirs: npt.NDArray[np.float64], report: PlaybackReport
) -> None:
    if not len(mine) or not len(theirs):
        return
    other = theirs[_at(theirs[:, 0], mine[:, 0])]
    gaps = np.abs(mine[:, 1] - other[:, 1])
    report.wheel_difference_mps = (round(float(np.median(gaps)), 4), round(float(gaps.max()), 4))
