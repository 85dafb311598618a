"""A replay's outputs against the recorded ones: poses at the recorded instants, the maps
(IoU of occupied cells), the last route of each goal, the goals' final states and the wheel
commands; the report says how far apart they came, when and in which part the largest
difference arose, and the first moment the replay left the recording behind.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

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
from navd.viz.record_codec import OUTPUTS

__all__ = ["OCCUPIED", "Outputs", "PlaybackReport", "compare", "map_iou"]

OCCUPIED = 50  # a cell above this [% occupied] is an obstacle when maps are compared
# Where a replay is said to have left the recording: each part's bound
POSE_APART_M = 0.1
WHEELS_APART_MPS = 0.1
MAP_AGREES_IOU = 0.95


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
    """What the replay gave against what was recorded (times [s] into the recording).

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
        worker_jobs: the recorded worker jobs, and of the replay's, those run as their
            recorded counterpart (``followed``), those without one (``unmatched``, run at
            once), and recorded ones never submitted again (``missed``).
        largest: the part whose largest difference is largest against its bound (pose
            0.1 m, wheels 0.1 m/s, map IoU below 0.95), when it was, and by how much.
        first_apart: the first moment a part went beyond its bound, and which (None: none
            did), where to look for why.
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
    worker_jobs: dict[str, int] = field(default_factory=dict)
    largest: dict[str, Any] | None = None
    first_apart: dict[str, Any] | None = None
    differences: list[str] = field(default_factory=list)

    def as_dict(self) -> dict[str, Any]:
        """The report as JSON can hold it."""
        return dataclasses.asdict(self)


class Outputs:
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
            self._wheels.append((t, message.linear_mps))  # when decided: stamps repeat
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


def _nearest(times: npt.NDArray[np.float64], t: npt.NDArray[np.float64]) -> npt.NDArray[np.intp]:
    """For each of ``t``, the index of the nearest of ``times`` (sorted)."""
    after = np.clip(np.searchsorted(times, t), 0, len(times) - 1)
    before = np.maximum(after - 1, 0)
    closer = np.abs(times[before] - t) <= np.abs(times[after] - t)
    return np.where(closer, before, after).astype(np.intp)


def _at(times: npt.NDArray[np.float64], t: npt.NDArray[np.float64]) -> npt.NDArray[np.intp]:
    """For each of ``t``, the index of the last of ``times`` at or before it (0 when none)."""
    found: npt.NDArray[np.intp] = np.searchsorted(times, t, side="right") - 1
    return np.maximum(found, 0)


def compare(
    recorded: Outputs,
    replayed: Outputs,
    maps: tuple[MapUpdate, MapUpdate | None] | None,
    map_ious: Sequence[tuple[float, float]] = (),
    origin_s: float = 0.0,
) -> PlaybackReport:
    """The report of ``replayed`` against ``recorded``: ``maps`` the last recorded map and
    the replay's of that time, ``map_ious`` (time [s], IoU) at each recorded map, times on
    the replay's clock, whose ``origin_s`` is the recording's start."""
    report = PlaybackReport(
        outputs={k: (recorded.counts[k], replayed.counts[k]) for k in recorded.counts}
    )
    # (part, time [s], by how much, its bound's multiple) where each part is worst/first out
    worst: list[tuple[str, float, float, float]] = []
    first: list[tuple[str, float, float]] = []
    poses = _compare_poses(recorded.poses, replayed.poses, report)
    if poses is not None:
        _track("pose", poses, POSE_APART_M, worst, first)
    if maps is not None:
        _compare_maps(*maps, report)
    if map_ious:
        shortfall = np.array([(t, 1.0 - iou) for t, iou in map_ious], dtype=np.float64)
        _track("map", shortfall, 1.0 - MAP_AGREES_IOU, worst, first)
    _compare_routes(recorded.routes, replayed.routes, report)
    _compare_goals(recorded.goals, replayed.goals, report)
    wheels = _compare_wheels(recorded.wheels, replayed.wheels, report)
    if wheels is not None:
        _track("wheels", wheels, WHEELS_APART_MPS, worst, first)
    if worst:
        part, at, by, _ = max(worst, key=lambda w: w[3])
        report.largest = {"part": part, "at_s": round(at - origin_s, 3), "by": round(by, 4)}
    if first:
        part, at, by = min(first, key=lambda f: f[1])
        report.first_apart = {"part": part, "at_s": round(at - origin_s, 3), "by": round(by, 4)}
        report.differences.append(
            f"first apart: {part} at {at - origin_s:.2f} s into the recording"
        )
    return report


def _track(
    part: str,
    gaps: npt.NDArray[np.float64],
    bound: float,
    worst: list[tuple[str, float, float, float]],
    first: list[tuple[str, float, float]],
) -> None:
    """Note where ``part``'s gaps (N x 2: time [s], how far apart) are largest, and the first
    beyond ``bound``."""
    if not len(gaps):
        return
    i = int(np.argmax(gaps[:, 1]))
    worst.append((part, float(gaps[i, 0]), float(gaps[i, 1]), float(gaps[i, 1]) / bound))
    out = np.flatnonzero(gaps[:, 1] > bound)
    if len(out):
        first.append((part, float(gaps[out[0], 0]), float(gaps[out[0], 1])))


def _compare_poses(
    mine: npt.NDArray[np.float64], theirs: npt.NDArray[np.float64], report: PlaybackReport
) -> npt.NDArray[np.float64] | None:
    """N x 2: each recorded pose's time and its distance to the replayed pose then."""
    if not len(mine) or not len(theirs):
        if len(mine) or len(theirs):
            report.differences.append(f"poses: {len(mine)} recorded, {len(theirs)} replayed")
        return None
    other = theirs[_at(theirs[:, 0], mine[:, 0])]
    errors = np.hypot(mine[:, 1] - other[:, 1], mine[:, 2] - other[:, 2])
    report.pose_error_m = (round(float(np.median(errors)), 4), round(float(errors.max()), 4))
    if report.pose_error_m[1] > POSE_APART_M:
        report.differences.append(
            f"poses: up to {report.pose_error_m[1]:.3f} m apart "
            f"(median {report.pose_error_m[0]:.3f} m)"
        )
    return np.column_stack((mine[:, 0], errors))


def _compare_maps(mine: MapUpdate, other: MapUpdate | None, report: PlaybackReport) -> None:
    if other is None:
        report.differences.append("map: the replay built none by the last recorded map's time")
        report.map_iou = 0.0
        return
    report.map_iou = round(map_iou(mine, other), 4)
    if report.map_iou < MAP_AGREES_IOU:
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
) -> npt.NDArray[np.float64] | None:
    """N x 2: each recorded command's time and its speed's gap to the replayed one then."""
    if not len(mine) or not len(theirs):
        return None
    # the replayed command decided nearest in time (two may come a few ms apart)
    other = theirs[_nearest(theirs[:, 0], mine[:, 0])]
    gaps = np.abs(mine[:, 1] - other[:, 1])
    report.wheel_difference_mps = (round(float(np.median(gaps)), 4), round(float(gaps.max()), 4))
    return np.column_stack((mine[:, 0], gaps))
