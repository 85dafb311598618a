"""The recorder module ("recorder"): the session to MCAP files, for replay and Foxglove.

It hears every input the daemon's edges put on the bus (sensor data, device comings and
goings, goals, cancels, initial poses, manual driving, map saves, config changes) and every
output it records (poses, localization, routes, wheel commands, goal progress, safety holds,
who drives, and the map at most every ``record.map_period_s``), and hands each to the
writer thread (see ``recording_writer``). Recording starts with the daemon
(``record.enabled``, ``navd run --record DIR``) or on a RecordRequest, and stops on one or
when the daemon stops. A folder that cannot be written is logged with the fix and the
daemon drives on unrecorded.
"""

from __future__ import annotations

import asyncio
import dataclasses
import math
import time

from navd.config import redacted_changes
from navd.lifecycle import Module, ModuleContext
from navd.lifecycle.messages import (
    ConfigChange,
    InitialPose,
    MapUpdate,
    Message,
    PoseEstimate,
    RecordingState,
    RecordRequest,
)
from navd.viz.record_codec import INFO, INPUTS, OUTPUTS, topic_of
from navd.viz.recording_writer import CLOSE_TIMEOUT_S, RecordingWriter
from navd.viz.settings import RecorderSettings

__all__ = ["Recorder", "RecorderSettings"]

# Messages kept while the writer is set up (some 10 ms; a slow disk: a few seconds at most).
MAX_EARLY = 20_000
# A recording's starting pose is never given as more certain than this [m], [rad].
MIN_SEED_STD_M = 0.01
MIN_SEED_STD_RAD = 0.005


class Recorder(Module):
    """Records the session while asked to (see the module docstring)."""

    def __init__(self) -> None:
        super().__init__("recorder")
        self.writer: RecordingWriter | None = None
        self._starting = False
        self._early: list[Message] = []  # what came while the writer was being set up
        self._offset_ns = 0  # wall clock minus daemon clock [ns], fixed at each start
        self._map_at = -float("inf")
        self._activated_s = 0.0  # [s] daemon time the module came up
        # What the daemon knew last, so a recording begun mid-run starts from it.
        self._last_pose: PoseEstimate | None = None
        self._last_map: MapUpdate | None = None

    async def on_configure(self, ctx: ModuleContext) -> None:
        self.ctx = ctx
        self.settings = ctx.settings(RecorderSettings.from_config)
        for kind in (*INPUTS, *OUTPUTS, *INFO):
            ctx.subscribe(kind, self._on_message)
        ctx.subscribe(RecordRequest, self._on_request)

    async def on_activate(self) -> None:
        self._activated_s = self.ctx.clock.now()
        if self.settings.value.enabled:
            started = self._begin("record.enabled")
            if started is not None:
                await started  # recording before the modules after this one speak

    async def on_deactivate(self) -> None:
        await self._stop("the daemon is stopping")

    def settings_in_use(self) -> tuple[object, ...]:
        """A recording keeps the folder and sizes it started with; the next one takes the
        settings then in force."""
        return (self.settings.value,)

    # --- starting and stopping ------------------------------------------------------------

    def _on_request(self, request: RecordRequest) -> None:
        who = request.source or "a client"
        if request.start:
            self._begin(who)
        else:
            self.ctx.spawn(self._stop(f"stopped by {who}"), name="record")

    def _begin(self, why: str) -> asyncio.Task[None] | None:
        """Start recording (the writer is set up off the loop); what comes meanwhile is kept
        and written first. None when already recording or starting."""
        if self.writer is not None or self._starting:
            self._publish_state()  # already recording (or about to): say where
            return None
        self._starting = True
        self._early.clear()
        return self.ctx.spawn(self._start(why), name="record")

    async def _start(self, why: str) -> None:
        s = self.settings.value
        now = self.ctx.clock.now()
        self._offset_ns = time.time_ns() - round(now * 1e9)
        self._map_at = -float("inf")
        loop = asyncio.get_running_loop()

        def failed(reason: str) -> None:  # the writer's thread
            loop.call_soon_threadsafe(self._writer_failed, reason)

        pose, known_map = self._last_pose, self._last_map
        header = {
            "began_s": now,  # [s] daemon time
            "into_run_s": round(now - self._activated_s, 3),
            "had_map": known_map is not None,
            "seeded_pose": pose is not None,
        }
        try:  # a folder made, old files deleted, a file opened: not on the loop
            writer = await asyncio.to_thread(
                RecordingWriter, s.writer, s.config_json, header, failed
            )
        except OSError as err:
            self._early.clear()
            reason = f"cannot write {s.writer.folder}: {err}"
            self.ctx.log.error(
                "record_failed",
                reason=reason,
                fix="check record.dir exists or can be made and this user may write it",
            )
            self._publish_state(reason)
            return
        finally:
            self._starting = False
        # Begun mid-run: the replay starts where the robot then was, and compares with the
        # map the daemon had then.
        if pose is not None:
            self._put(writer, _seed(pose, now))
        if known_map is not None:
            self._put(writer, known_map)
        for message in self._early:  # what came meanwhile, in order
            self._put(writer, message)
        self._early.clear()
        self.writer = writer
        self.ctx.log.info("recording", file=str(writer.file), asked_by=why, **header)
        self._publish_state()

    async def _stop(self, why: str) -> None:
        writer, self.writer = self.writer, None
        if writer is None:
            return
        closed = await asyncio.to_thread(writer.close)  # the last chunk, the index: off the loop
        if not closed:
            self.ctx.log.warning(
                "record_close_slow",
                file=str(writer.file),
                waited_s=CLOSE_TIMEOUT_S,
                fix="the disk is slow or stuck; the file is readable to its last flush",
            )
        self.ctx.log.info(
            "recording_stopped",
            file=str(writer.file),
            reason=why,
            messages=writer.written,
            dropped=writer.dropped,
            old_files_deleted=writer.files_deleted,
        )
        self._publish_state(why)

    def _writer_failed(self, reason: str) -> None:
        """Event loop: the writer thread could not go on (a full disk)."""
        writer, self.writer = self.writer, None
        if writer is None:
            return
        self.ctx.log.error(
            "record_failed",
            file=str(writer.file),
            reason=reason,
            fix="if the disk is full, free space or lower record.budget_mb; the file is "
            "readable to its last chunk. The daemon drives on unrecorded",
        )
        self._publish_state(reason)

    def _publish_state(self, reason: str = "") -> None:
        now = self.ctx.clock.now()
        writer = self.writer
        self.ctx.publish(
            RecordingState(
                stamp=now,
                received=now,
                active=writer is not None,
                file="" if writer is None else str(writer.file),
                reason=reason,
            )
        )

    # --- messages (event loop: one append each) -------------------------------------------

    def _on_message(self, message: Message) -> None:
        if isinstance(message, PoseEstimate):
            self._last_pose = message
        writer = self.writer
        if isinstance(message, MapUpdate):
            self._last_map = message
            if writer is None or message.stamp - self._map_at < self.settings.value.map_period_s:
                return
            self._map_at = message.stamp
        if isinstance(message, ConfigChange):  # a secret sent in a change is not kept either
            message = dataclasses.replace(message, changes=redacted_changes(message.changes))
        if writer is not None:
            self._put(writer, message)
        elif self._starting and len(self._early) < MAX_EARLY:
            self._early.append(message)

    def _put(self, writer: RecordingWriter, message: Message) -> None:
        topic = topic_of(type(message))
        assert topic is not None
        writer.put(topic, message, self._offset_ns + round(message.received * 1e9))


def _seed(pose: PoseEstimate, now: float) -> InitialPose:
    """Where the robot was when a recording began, as the replay's initial pose."""
    cov = pose.covariance
    return InitialPose(
        stamp=now,
        received=now,
        x_m=pose.x_m,
        y_m=pose.y_m,
        yaw_rad=pose.yaw_rad,
        std_xy_m=max(math.sqrt(max(cov[0, 0], cov[1, 1], 0.0)), MIN_SEED_STD_M),
        std_yaw_rad=max(math.sqrt(max(cov[2, 2], 0.0)), MIN_SEED_STD_RAD),
    )
