"""Reading a recording back: one session, from one MCAP file or a folder of them.

A folder may hold several sessions (``navd-<session>-<n>.mcap``); one is read: the one
asked for, or the folder's only one. Files are read front to back with the MCAP reference
reader, one message at a time (a long recording is never held whole), so a file without its
end (the daemon was killed) gives everything up to its last whole chunk and is named in
``cut_short``.
"""

from __future__ import annotations

import json
import struct
from collections.abc import Collection, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import zstandard
from mcap.exceptions import InvalidMagic, McapError
from mcap.reader import NonSeekingReader

from navd.lifecycle.messages import Message
from navd.viz.errors import RecordingError
from navd.viz.record_codec import CONFIG_TOPIC, SESSION_TOPIC, RecordCodecError, decode
from navd.viz.recording_writer import recording_files, session_of

__all__ = ["Recording", "RecordingError", "read_recording"]


@dataclass
class Recording:
    """One recorded session.

    Attributes:
        files: its files, in order.
        config: the config the daemon ran on (JSON fields; the first file's).
        header: the session's header (name, when it began in the daemon's run, what the
            daemon knew then); empty for a recording without one.
        cut_short: files that ended mid-way (read up to their last whole chunk), filled as
            ``messages`` reads them.
        unreadable: messages skipped, with why (a topic of a newer navd...).
    """

    files: list[Path]
    config: dict[str, Any]
    header: dict[str, Any] = field(default_factory=dict)
    cut_short: list[Path] = field(default_factory=list)
    unreadable: list[str] = field(default_factory=list)

    def messages(self, topics: Collection[str] | None = None) -> Iterator[tuple[str, Message]]:
        """(topic, message) in the order they were recorded, file after file; only those on
        ``topics`` when given (the others are not decoded)."""
        for file in self.files:
            for topic, data in _records(file, self.cut_short):
                if topic in (CONFIG_TOPIC, SESSION_TOPIC):
                    continue
                if topics is not None and topic not in topics:
                    continue
                try:
                    yield topic, decode(topic, data)
                except RecordCodecError as err:
                    self.unreadable.append(str(err))


def _records(path: Path, cut_short: list[Path]) -> Iterator[tuple[str, bytes]]:
    """(topic, data) of each message in ``path``, up to where it ends or breaks off.

    Raises:
        RecordingError: the file is not MCAP.
    """
    try:
        with path.open("rb") as stream:
            reader = NonSeekingReader(stream)
            for _, channel, message in reader.iter_messages(log_time_order=False):
                yield channel.topic, message.data
    except InvalidMagic as err:
        raise RecordingError(f"{path} is not an MCAP file: {err}") from err
    except (McapError, EOFError, ValueError, struct.error, zstandard.ZstdError):
        if path not in cut_short:
            cut_short.append(path)  # killed mid-write: the whole chunks before count


def _session_files(path: Path, session: str | None) -> list[Path]:
    if not path.exists():
        raise RecordingError(f"{path} does not exist")
    if not path.is_dir():
        if session is not None and session_of(path) != session:
            raise RecordingError(f"{path} is of session {session_of(path)!r}, not {session!r}")
        return [path]
    files = recording_files(path) or sorted(path.glob("*.mcap"))
    if not files:
        raise RecordingError(f"{path} holds no .mcap recordings")
    sessions: dict[str, list[Path]] = {}
    for file in files:
        sessions.setdefault(session_of(file), []).append(file)
    if session is not None:
        if session not in sessions:
            raise RecordingError(
                f"{path} holds no session {session!r}; it holds {', '.join(sessions)}"
            )
        return sessions[session]
    if len(sessions) > 1:
        raise RecordingError(
            f"{path} holds {len(sessions)} sessions ({', '.join(sessions)}); name one with "
            f"--session, or give one of its files"
        )
    return files


def _head(path: Path) -> tuple[dict[str, Any] | None, dict[str, Any]]:
    """The config and the session header at the start of ``path``."""
    config: dict[str, Any] | None = None
    header: dict[str, Any] = {}
    for topic, data in _records(path, []):
        if topic not in (CONFIG_TOPIC, SESSION_TOPIC):
            break
        try:
            value = json.loads(data)
        except (UnicodeDecodeError, json.JSONDecodeError, RecursionError) as err:
            raise RecordingError(f"{path}: its {topic} is not JSON: {err!r}") from err
        if not isinstance(value, dict):
            raise RecordingError(f"{path}: its {topic} is not a JSON object")
        if topic == CONFIG_TOPIC:
            config = value
        else:
            header = value
    return config, header


def read_recording(path: Path, session: str | None = None) -> Recording:
    """The session recorded in ``path`` (a file, or a folder), ready to be read.

    Args:
        path: one recording file, or a folder of them.
        session: which session of a folder (None: its only one).

    Raises:
        RecordingError: no such file, no recordings, several sessions and none named, a file
            that is not MCAP, or a recording without its config.
    """
    files = _session_files(path, session)
    config, header = _head(files[0])
    if config is None:
        raise RecordingError(f"{files[0]}: no config at its start; is it a navd recording?")
    return Recording(files=files, config=config, header=header)
