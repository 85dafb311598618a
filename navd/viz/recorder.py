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
import json
import time
from dataclasses import dataclass, field
from pathlib import Path

from navd.config import NavdConfig
from navd.config.loader import redacted, redacted_changes
from navd.lifecycle.messages import (
    ConfigChange,
    MapUpdate,
    Message,
    RecordingState,
    RecordRequest,
)
from navd.lifecycle.module import Module, ModuleContext
from navd.viz.record_codec import INFO, INPUTS, OUTPUTS, topic_of
from navd.viz.recording_writer import RecordingWriter, WriterSettings

__all__ = ["Recorder", "RecorderSettings"]

MB = 1_000_000


@dataclass(frozen=True, slots=True)
class RecorderSettings:
    """The record section's values, and the config as a recording carries it.

    Attributes:
        enabled: record from start-up.
        writer: where and how files are written.
        map_period_s: [s] least time between two recorded maps.
        config_json: the whole config without its secrets (JSON).
    """

    enabled: bool
    writer: WriterSettings
    map_period_s: float
    config_json: bytes = field(repr=False)

    @classmethod
    def from_config(cls, config: NavdConfig) -> RecorderSettings:
        """The settings the record section describes; the token is never recorded."""
        record = config.record
        return cls(
            enabled=record.enabled,
            writer=WriterSettings(
                folder=Path(record.dir),
                max_file_bytes=int(record.max_file_mb * MB),
                budget_bytes=int(record.budget_mb * MB),
                flush_period_s=record.flush_period_s,
            ),
            map_period_s=record.map_period_s,
            config_json=json.dumps(redacted(config)).encode(),
        )


class Recorder(Module):
    """Records the session while asked to (see the module docstring)."""

    def __init__(self) -> None:
        super().__init__("recorder")
        self.writer: RecordingWriter | None = None
        self._offset_ns = 0  # wall clock minus daemon clock [ns], fixed at each start
        self._map_at = -float("inf")

    async def on_configure(self, ctx: ModuleContext) -> None:
        self.ctx = ctx
        self.settings = ctx.settings(RecorderSettings)
        for kind in (*INPUTS, *OUTPUTS, *INFO):
            ctx.subscribe(kind, self._on_message)
        ctx.subscribe(RecordRequest, self._on_request)

    async def on_activate(self) -> None:
        if self.settings.value.enabled:
            self._start("record.enabled")

    async def on_deactivate(self) -> None:
        await self._stop("the daemon is stopping")

    def settings_in_use(self) -> tuple[object, ...]:
        """A recording keeps the folder and sizes it started with; the next one takes the
        settings then in force."""
        return (self.settings.value,)

    # --- starting and stopping ------------------------------------------------------------

    def _on_request(self, request: RecordRequest) -> None:
        if request.start:
            self._start(request.source or "a client")
        else:
            self.ctx.spawn(self._stop(f"stopped by {request.source or 'a client'}"), name="record")

    def _start(self, why: str) -> None:
        if self.writer is not None:
            self._publish_state()  # already recording: say where
            return
        s = self.settings.value
        self._offset_ns = time.time_ns() - round(self.ctx.clock.now() * 1e9)
        self._map_at = -float("inf")
        loop = asyncio.get_running_loop()

        def failed(reason: str) -> None:  # the writer's thread
            loop.call_soon_threadsafe(self._writer_failed, reason)

        try:
            self.writer = RecordingWriter(s.writer, s.config_json, failed)
        except OSError as err:
            reason = f"cannot write {s.writer.folder}: {err}"
            self.ctx.log.error(
                "record_failed",
                reason=reason,
                fix="check record.dir exists or can be made and this user may write it",
            )
            self._publish_state(reason)
            return
        self.ctx.log.info("recording", file=str(self.writer.file), asked_by=why)
        self._publish_state()

    async def _stop(self, why: str) -> None:
        writer, self.writer = self.writer, None
        if writer is None:
            return
        await asyncio.to_thread(writer.close)  # the last chunk and the index: off the loop
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
            fix="free disk space or lower record.budget_mb; the file is readable to its last "
            "chunk. The daemon drives on unrecorded",
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
        writer = self.writer
        if writer is None:
            return
        if isinstance(message, MapUpdate):
            if message.stamp - self._map_at < self.settings.value.map_period_s:
                return
            self._map_at = message.stamp
        if isinstance(message, ConfigChange):  # a secret sent in a change is not kept either
            message = dataclasses.replace(message, changes=redacted_changes(message.changes))
        topic = topic_of(type(message))
        assert topic is not None
        writer.put(topic, message, self._offset_ns + round(message.received * 1e9))
