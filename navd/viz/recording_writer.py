"""Writing a recording: MCAP files in a folder, in a thread of their own.

The event loop only appends (topic, message, time) to a bounded queue. The writer thread
wakes every ``flush_period_s``, encodes what came (``record_codec``), logs it through
foxglove-sdk's MCAP writer, finishes the chunk and has the file synced to the disk, so a
file cut by a crash, a kill -9 or a power cut is readable up to its last flush. A file that
reaches ``max_file_bytes`` is closed (with its index, for fast seeking) and the next one
begun; after each new file the oldest recordings in the folder are deleted until the folder
is under ``budget_bytes``.

One recording is one session: its files are named ``navd-<session>-<n>.mcap``, the session
being the UTC time it began and a random suffix, so several sessions share a folder without
mixing and a restart within the same second starts a session of its own. Each file starts
with the config and the session's header (``SESSION_TOPIC``), so it replays on its own.
Beside navd's messages it holds what a viewer draws (``recording_view``).
"""

from __future__ import annotations

import collections
import json
import os
import secrets
import threading
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import foxglove
from foxglove import Channel, Context, Schema
from foxglove.mcap import MCAPCompression, MCAPWriteOptions, MCAPWriter

from navd.config import LidarConfig, MountsConfig
from navd.geometry import SensorMounts
from navd.lifecycle.messages import Message
from navd.viz.record_codec import CONFIG_TOPIC, SESSION_TOPIC, encode
from navd.viz.record_schema import schema_bytes, topic_schema
from navd.viz.recording_view import RecordingView

__all__ = [
    "CLOSE_TIMEOUT_S",
    "MAX_QUEUED",
    "RecordingWriter",
    "WriterSettings",
    "new_session",
    "recording_files",
    "session_of",
]

# Messages waiting for the writer at most (some 10 s at full sensor load); beyond, the
# oldest are dropped and counted: the daemon's memory is never the recording's to take.
MAX_QUEUED = 20_000
CLOSE_TIMEOUT_S = 10.0  # [s] closing waits this long for the last write (a stuck disk)
FILE_PATTERN = "navd-*.mcap"


@dataclass(frozen=True, slots=True)
class WriterSettings:
    """Where and how a recording is written.

    Attributes:
        folder: the recordings' folder.
        max_file_bytes: a file this large is closed and the next begun.
        budget_bytes: the folder's recordings are kept under this.
        flush_period_s: [s] data reaches the disk, a whole chunk, this often.
        mounts: where the lidars sit (the scans a viewer draws, in their frames).
    """

    folder: Path
    max_file_bytes: int
    budget_bytes: int
    flush_period_s: float
    mounts: SensorMounts = field(
        default_factory=lambda: SensorMounts.of(MountsConfig(), LidarConfig())
    )


def new_session() -> str:
    """A session name: the UTC time it begins and a random suffix (``20261202-031500-a1b2c3``)."""
    return f"{time.strftime('%Y%m%d-%H%M%S', time.gmtime())}-{secrets.token_hex(3)}"


def recording_files(folder: Path) -> list[Path]:
    """The folder's recordings, oldest first (their names sort by time)."""
    return sorted(folder.glob(FILE_PATTERN))


def session_of(path: Path) -> str:
    """The session a recording file belongs to (its name without prefix and number)."""
    stem = path.stem
    return stem.removeprefix("navd-").rsplit("-", 1)[0] if stem.startswith("navd-") else stem


class RecordingWriter:
    """Writes one recording session into ``settings.folder`` (blocking set-up: make it off
    the event loop).

    Args:
        settings: where and how.
        config_json: the config the daemon runs on (JSON), first in every file.
        header: the session's header (JSON fields), second in every file, with the file's
            index added.
        failed: called from the writer thread with the reason when writing fails (the
            recording has then stopped).

    Raises:
        OSError: the folder cannot be made or the first file cannot be opened.
    """

    def __init__(
        self,
        settings: WriterSettings,
        config_json: bytes,
        header: Mapping[str, Any],
        failed: Callable[[str], None],
    ) -> None:
        self.settings = settings
        self.session = new_session()
        self._config_json = config_json
        self._header = dict(header)
        self._failed = failed
        self._queue: collections.deque[tuple[str, Message, int]] = collections.deque()
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self.dropped = 0
        self.written = 0
        self.files_deleted = 0
        settings.folder.mkdir(parents=True, exist_ok=True)
        self._context = Context()
        self._channels: dict[str, Channel] = {}
        self._view = RecordingView(self._context, settings.mounts)
        self._sequence = 0
        self._writer: MCAPWriter | None = None
        self._sync_fd: int | None = None
        self.file = self._open()
        self._thread = threading.Thread(target=self._run, name="recorder", daemon=True)
        self._thread.start()

    # --- event loop -------------------------------------------------------------------

    def put(self, topic: str, message: Message, log_time_ns: int) -> None:
        """Queue a message (cheap: no encoding here)."""
        with self._lock:
            if len(self._queue) >= MAX_QUEUED:
                self._queue.popleft()
                self.dropped += 1
            self._queue.append((topic, message, log_time_ns))

    def close(self) -> bool:
        """Write what is queued, close the file with its index, and end the thread (blocking:
        call it off the event loop). False if that took longer than CLOSE_TIMEOUT_S (the
        thread finishes on its own; the file is readable to its last flush meanwhile)."""
        self._stop.set()
        self._thread.join(CLOSE_TIMEOUT_S)
        return not self._thread.is_alive()

    # --- writer thread ----------------------------------------------------------------

    def _run(self) -> None:
        try:
            while not self._stop.wait(self.settings.flush_period_s):
                self._write_queued()
            self._write_queued()
        except Exception as err:  # a full disk, a folder removed, or a bug: said, not hidden
            self._failed(f"{type(err).__name__}: {err}")
        finally:
            self._close_file()

    def _write_queued(self) -> None:
        with self._lock:
            batch, self._queue = self._queue, collections.deque()
        for topic, message, log_time_ns in batch:
            self._channel(topic).log(encode(message), log_time=log_time_ns)
            self._view.log(message, log_time_ns)  # and as a viewer draws it
        self.written += len(batch)
        assert self._writer is not None
        self._writer.flush()  # a whole chunk in the file: readable after a crash
        if self._sync_fd is not None:
            os.fsync(self._sync_fd)  # and on the disk: after a power cut too
        if self.file.stat().st_size >= self.settings.max_file_bytes:
            self._close_file()
            self.file = self._open()

    def _close_file(self) -> None:
        if self._writer is not None:
            try:
                self._writer.close()
            except Exception as err:  # the file stays readable to its last chunk
                self._failed(f"closing {self.file}: {type(err).__name__}: {err}")
            self._writer = None
        if self._sync_fd is not None:
            os.close(self._sync_fd)
            self._sync_fd = None

    def _channel(self, topic: str) -> Channel:
        channel = self._channels.get(topic)
        if channel is None:
            named = topic_schema(topic)
            schema = None
            if named is not None:  # what the JSON holds, for a viewer and for any reader
                name, body = named
                schema = Schema(name=name, encoding="jsonschema", data=schema_bytes(body))
            channel = Channel(topic, schema=schema, message_encoding="json", context=self._context)
            self._channels[topic] = channel
        return channel

    def _open(self) -> Path:
        """Begin the next file (the config and the header first in it), then keep the folder
        in budget."""
        self._sequence += 1
        path = self.settings.folder / f"navd-{self.session}-{self._sequence:04d}.mcap"
        options = MCAPWriteOptions(compression=MCAPCompression.Zstd, profile="navd")
        self._writer = foxglove.open_mcap(path, context=self._context, writer_options=options)
        try:
            self._sync_fd = os.open(path, os.O_RDONLY)
            now_ns = time.time_ns()
            self._channel(CONFIG_TOPIC).log(self._config_json, log_time=now_ns)
            header = {**self._header, "session": self.session, "file_index": self._sequence}
            self._channel(SESSION_TOPIC).log(json.dumps(header).encode(), log_time=now_ns)
            self._keep_in_budget(path)
        except BaseException:
            self._close_file()
            raise
        return path

    def _keep_in_budget(self, current: Path) -> None:
        files = [f for f in recording_files(self.settings.folder) if f != current]
        total = sum(f.stat().st_size for f in files)
        for old in files:
            if total <= self.settings.budget_bytes - self.settings.max_file_bytes:
                break
            total -= old.stat().st_size
            old.unlink(missing_ok=True)
            self.files_deleted += 1
