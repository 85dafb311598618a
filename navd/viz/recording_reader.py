"""Reading a recording back: one MCAP file, or a folder of them in time order.

Files are read front to back with the MCAP reference reader, so a file without its end (the
daemon was killed) gives everything up to its last whole chunk and says it was cut short.
"""

from __future__ import annotations

import json
import struct
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import zstandard
from mcap.exceptions import InvalidMagic, McapError
from mcap.reader import NonSeekingReader

from navd.lifecycle.messages import Message
from navd.viz.record_codec import CONFIG_TOPIC, RecordCodecError, decode
from navd.viz.recording_writer import recording_files

__all__ = ["Recording", "RecordingError", "read_recording"]


class RecordingError(ValueError):
    """A recording that cannot be read: the message names the file and why."""


@dataclass
class Recording:
    """A recording read whole.

    Attributes:
        files: the files read, in order.
        config: the config the daemon ran on (JSON fields; the first file's).
        messages: (topic, message) in the order they were recorded.
        cut_short: files that ended mid-way (read up to their last whole chunk).
        unreadable: messages skipped, with why (a topic of a newer navd...).
    """

    files: list[Path]
    config: dict[str, Any] | None = None
    messages: list[tuple[str, Message]] = field(default_factory=list)
    cut_short: list[Path] = field(default_factory=list)
    unreadable: list[str] = field(default_factory=list)


def _paths(path: Path) -> list[Path]:
    if path.is_dir():
        files = recording_files(path) or sorted(path.glob("*.mcap"))
        if not files:
            raise RecordingError(f"{path} holds no .mcap recordings")
        return files
    if not path.exists():
        raise RecordingError(f"{path} does not exist")
    return [path]


def _records(path: Path, recording: Recording) -> Iterator[tuple[str, bytes]]:
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
        recording.cut_short.append(path)  # killed mid-write: the whole chunks before count


def read_recording(path: Path) -> Recording:
    """The recording in ``path`` (a file, or a folder of them).

    Raises:
        RecordingError: no such file, no recordings in the folder, a file that is not MCAP,
            or a recording without its config.
    """
    recording = Recording(files=_paths(path))
    for file in recording.files:
        for topic, data in _records(file, recording):
            if topic == CONFIG_TOPIC:
                if recording.config is None:
                    recording.config = json.loads(data)
                continue
            try:
                recording.messages.append((topic, decode(topic, data)))
            except RecordCodecError as err:
                recording.unreadable.append(str(err))
    if recording.config is None:
        raise RecordingError(f"{path}: no config in the recording; is it a navd recording?")
    return recording
