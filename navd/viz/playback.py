"""Replaying a recording through the whole pipeline, and where it differs from the original.

The daemon runs here, in this process, on simulated time, with the modules the recorded
config gives it except its edges (the TCP server, the chassis, the live view, the recorder):
the recorded inputs take their place. Each input is put on the bus at its recorded arrival
time (shifted so the replay starts at ``START_S``), after the clock has moved there one
timer at a time and the work due has finished (the lockstep of ``navd.lifecycle.lockstep``),
so estimation, SLAM and planning run with no time of their own, except that each worker job
(a scan match, a plan) runs as the recorded one did: dropped if it was, else begun and
published after the recorded delays (``WorkScript``), and each module's periodic loop ticks
when it did (``LoopTimes``), so a real-time run's lags are played again. The outputs are
kept and compared with the recorded ones (``replay_report``): poses
at the recorded instants, the maps (IoU of occupied cells), the last route of each goal, the
goals' final states, the wheel commands; and when and where the replay first left the
recording.

Maps go to a folder of the replay's own, never the robot's.
"""

from __future__ import annotations

import asyncio
import dataclasses
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from pydantic import ValidationError

from navd import __version__
from navd.config import NavdConfig
from navd.lifecycle import Daemon, Lockstep, Module, SimClock, WorkScript
from navd.lifecycle.messages import LoopTicks, MapUpdate, Message, SetUpDone, WorkerJob
from navd.viz.errors import RecordingError
from navd.viz.record_codec import OUTPUTS, topic_of
from navd.viz.recording_reader import Recording
from navd.viz.replay_report import Outputs, PlaybackReport, compare, map_iou

__all__ = ["EDGE_MODULES", "PlaybackReport", "map_iou", "play", "replay_config"]  # the report's
# names too (``replay_report``), where callers find them

START_S = 1.0  # [s] simulated time of the first input
AFTER_S = 2.0  # [s] the replay runs on this long past the last input
EDGE_MODULES = frozenset({"tcp", "chassis", "viz", "recorder"})  # their inputs are recorded
WORK_TOPIC = str(topic_of(WorkerJob))  # the worker jobs' timing, which the replay follows
TICKS_TOPIC = str(topic_of(LoopTicks))  # and the periodic loops' ticks
SET_UP_TOPIC = str(topic_of(SetUpDone))  # and when the modules' set-ups took effect
MAP_TOPIC = str(topic_of(MapUpdate))
STEP_TIMEOUT_S = 600.0  # [s] real time a step may wait for start-up work (kernels compiling)


def replay_config(
    recorded: dict[str, Any], maps: Path, start_map: Path | None = None
) -> NavdConfig:
    """The recorded config, run on simulated time without its edges, saving maps to
    ``maps``; starting from ``start_map`` (a map's YAML) when given.

    Raises:
        RecordingError: the recorded config does not suit this navd (a key it does not know,
            from another version), naming the keys.
    """
    try:
        plain = _replayable(recorded, maps)
        if start_map is not None:
            plain["slam"]["load_map"] = str(start_map)
        return NavdConfig.model_validate(plain)
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


def _shifted(message: Message, shift_s: float) -> Message:
    return dataclasses.replace(
        message, stamp=message.stamp + shift_s, received=message.received + shift_s
    )


class _Feed:
    """Puts a recording's inputs on a daemon's bus at their instants, and keeps the
    recorded outputs beside the replayed ones."""

    def __init__(
        self, daemon: Daemon, lockstep: Lockstep, replayed: Outputs, script: WorkScript
    ) -> None:
        self.daemon = daemon
        self.script = script
        self.lockstep = lockstep
        self.replayed = replayed
        self.recorded = Outputs()
        self.early: list[Message] = []  # outputs before the first input: shifted once known
        self.shift: float | None = None  # [s] replay time minus recorded time
        self.first = self.last = 0.0  # [s] recorded times of the first and last inputs
        self.inputs = 0
        # The last recorded map, and the replay's map when the recording reached it (the
        # replay keeps pace with the recording's inputs).
        self.maps: tuple[MapUpdate, MapUpdate | None] | None = None
        self.map_ious: list[tuple[float, float]] = []  # (replay time [s], IoU) of each map
        self._maps_due: list[tuple[float, MapUpdate]] = []  # recorded maps still to compare

    async def take(self, topic: str, message: Message) -> None:
        if topic.startswith("/navd/out/"):
            if isinstance(message, MapUpdate):
                self.maps = (message, self.replayed.map)
                # compared when the replay has reached its time; one from before the first
                # input is where a mid-run recording starts, not something the replay made
                if self.shift is not None and message.received >= self.first:
                    self._maps_due.append((message.received + self.shift, message))
            if self.shift is None:
                self.early.append(message)
            else:
                self.recorded.add(message, self.shift)
            return
        if not topic.startswith("/navd/in/"):
            return
        if self.shift is None:
            self.shift = START_S - message.received
            self.script.shift_s = self.daemon.loop_times.shift_s = self.shift
            self.first = message.received
            for early in self.early:
                self.recorded.add(early, self.shift)
            self.early.clear()
        moved = _shifted(message, self.shift)
        if moved.received > self.daemon.clock.now():
            await self.lockstep.step_to(moved.received, {}, STEP_TIMEOUT_S)
        self._compare_maps(self.daemon.clock.now())
        self.daemon.bus.publish(moved)
        self.inputs += 1
        self.last = message.received

    async def finish(self) -> None:
        """Run on past the last input (the work it started ends)."""
        if self.shift is None:
            raise RecordingError("the recording holds no inputs to replay")
        await self.lockstep.step_to(self.last + self.shift + AFTER_S, {}, STEP_TIMEOUT_S)
        self._compare_maps(float("inf"))

    def _compare_maps(self, now: float) -> None:
        """Each recorded map of ``now`` or before against the replay's map now (the replay's
        clock has reached it; the last recorded map is compared so as well)."""
        while self._maps_due and self._maps_due[0][0] <= now:
            at, recorded = self._maps_due.pop(0)
            mine = self.replayed.map
            self.map_ious.append((at, 0.0 if mine is None else map_iou(recorded, mine)))
            if self.maps is not None and self.maps[0] is recorded:
                self.maps = (recorded, mine)


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
    config = replay_config(recording.config, work_dir / "maps", _start_map(recording, work_dir))
    modules = [m for m in build(config) if m.name not in EDGE_MODULES]
    daemon = Daemon(config, modules, handle_signals=False)
    # read first: a job's or a tick's record comes after it
    timed = [m for _, m in recording.messages(topics={WORK_TOPIC, TICKS_TOPIC, SET_UP_TOPIC})]
    jobs = [m for m in timed if isinstance(m, WorkerJob)]
    script = WorkScript(jobs, (m for m in timed if isinstance(m, SetUpDone)))
    if jobs:
        daemon.workers.follow(script)
    daemon.loop_times.follow(m for m in timed if isinstance(m, LoopTicks))
    replayed = Outputs()
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
        lockstep = Lockstep(daemon.clock, daemon.workers, daemon.line_counts)
        feed = _Feed(daemon, lockstep, replayed, script)
        for topic, message in recording.messages():
            await feed.take(topic, message)
        await feed.finish()
    finally:
        replaying = False
        daemon.request_shutdown("replay over")
        await asyncio.wait_for(task, 60.0)
    report = compare(feed.recorded, replayed, feed.maps, feed.map_ious, START_S)
    report.worker_jobs = {
        "recorded": len(script),
        "followed": script.followed,
        "unmatched": script.unmatched,
        "missed": script.missed,
    }
    report.inputs = feed.inputs
    report.duration_s = round(feed.last - feed.first, 3)
    report.cut_short = [str(p) for p in recording.cut_short]
    header = recording.header
    if header.get("had_map") or header.get("seeded_pose"):
        report.differences.insert(
            0,
            f"the recording began {header.get('into_run_s', '?')} s into the daemon's run: "
            "the replay starts from the pose the robot had then"
            + (" and the map the daemon had built" if header.get("had_map") else ""),
        )
    return report


def _start_map(recording: Recording, work_dir: Path) -> Path | None:
    """A recording begun mid-run holds the map the daemon had then (first): saved where the
    replay starts from it; None for a recording that began without one."""
    if not recording.header.get("had_map"):
        return None
    first = next((m for _, m in recording.messages(topics={MAP_TOPIC})), None)
    if not isinstance(first, MapUpdate):
        return None
    from navd.slam import OccupancyGrid, save_map  # noqa: PLC0415 (numba: only when needed)

    grid = OccupancyGrid.from_percent(
        first.occupancy, first.origin_x_m, first.origin_y_m, first.resolution_m
    )
    return save_map(grid, work_dir / "start", "recorded-start", image_stem="recorded-start")
