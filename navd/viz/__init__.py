"""The live view: what navd thinks, streamed to Foxglove or Lichtblick while it runs (an edge
room, like drivers: it listens to the bus and never reaches into the other rooms)."""

from navd.viz.errors import CommandRefusedError, RecordCodecError, RecordingError, VizError
from navd.viz.layout import lichtblick_layout, live_layout
from navd.viz.node import VizNode
from navd.viz.playback import play
from navd.viz.recorder import Recorder
from navd.viz.recording_reader import read_recording
from navd.viz.recording_writer import CLOSE_TIMEOUT_S, recording_files

__all__ = [
    "CLOSE_TIMEOUT_S",
    "CommandRefusedError",
    "RecordCodecError",
    "Recorder",
    "RecordingError",
    "VizError",
    "VizNode",
    "lichtblick_layout",
    "live_layout",
    "play",
    "read_recording",
    "recording_files",
]
