"""``navd mission run|status|pause|resume|cancel|continue``: missions on the running daemon."""

from __future__ import annotations

import argparse
import json
import math
import sys
import tomllib
from pathlib import Path
from typing import Any

from navd.cli.common import (
    EXIT_CANCELED,
    EXIT_FAILED,
    EXIT_OK,
    EXIT_USAGE,
    Commands,
    connect,
    connection_options,
)
from navd.config import ConfigError
from navd.wire import (
    Client,
    ClientError,
    MissionControlFrame,
    MissionDocumentError,
    MissionFrame,
    MissionStatusFrame,
    StatusFrame,
    SubscribeFrame,
    frame_text,
    mission_from_document,
)

__all__ = ["add_commands", "load_mission", "mission_line"]

ENDED = ("completed", "failed", "canceled")
MAX_FILE_BYTES = 1 << 20
KEEP_ALIVE_HZ = 0.1  # [Hz] status frames a following client takes (they keep it connected)


def add_commands(commands: Commands) -> None:
    """Add ``mission``."""
    mission = commands.add_parser(
        "mission", help="run a mission from a file, follow it, pause, resume or cancel it"
    )
    actions = mission.add_subparsers(dest="mission_command", metavar="ACTION", required=True)
    run = actions.add_parser("run", help="send a mission file (TOML or JSON) to navd")
    run.add_argument("file", type=Path, help="the mission (see docs/missions.md)")
    run.add_argument("--id", dest="mission_id", help="the mission's id (default: chosen by navd)")
    run.add_argument(
        "--wait",
        action="store_true",
        help="follow it to its end, a line per step; exit 0 completed, 1 failed, 3 canceled",
    )
    run.add_argument(
        "--json",
        action="store_true",
        help="print navd's answer (and with --wait its reports) as raw JSON frames",
    )
    connection_options(run)
    run.set_defaults(handler=_run)
    status = actions.add_parser("status", help="print where the mission is")
    connection_options(status)
    status.set_defaults(handler=_status)
    for action, words in (
        ("pause", "pause the mission (its goal is cancelled; resume takes it up again)"),
        ("resume", "take a paused mission up again at its step"),
        ("cancel", "stop the mission"),
        ("continue", "let a pause step go on"),
    ):
        command = actions.add_parser(action, help=words)
        connection_options(command)
        command.set_defaults(handler=_control, action=action)


def load_mission(path: Path, mission_id: str | None = None) -> MissionFrame:
    """The mission in a TOML (``.toml``) or JSON file.

    Raises:
        ConfigError: the file cannot be read or parsed, or a field is wrong (named).
    """
    source = f"mission file {path}"
    try:
        raw = path.read_bytes()[: MAX_FILE_BYTES + 1]
    except OSError as err:
        raise ConfigError([f"cannot be read: {err.strerror}"], source=source) from err
    if len(raw) > MAX_FILE_BYTES:
        raise ConfigError([f"larger than {MAX_FILE_BYTES} bytes: not a mission"], source=source)
    try:
        text = raw.decode("utf-8")
        data: Any = tomllib.loads(text) if path.suffix == ".toml" else json.loads(text)
    except (UnicodeDecodeError, tomllib.TOMLDecodeError, json.JSONDecodeError) as err:
        kind = "TOML" if path.suffix == ".toml" else "JSON"
        raise ConfigError([f"not valid {kind}: {err}"], source=source) from err
    except RecursionError as err:
        raise ConfigError(["nested too deep to be a mission"], source=source) from err
    if not isinstance(data, dict):
        raise ConfigError(["a mission is a table (an object) with steps"], source=source)
    try:
        return mission_from_document(data, mission_id)
    except MissionDocumentError as err:
        raise ConfigError(err.problems, source=source) from err


def _size(mission: MissionFrame) -> str:
    """How long a mission is, in words: 3 steps; 1 step, 2 rounds; 4 steps, until canceled."""
    steps = len(mission.steps)
    text = f"{steps} step{'s' if steps != 1 else ''}"
    if mission.rounds == 0:
        return text + ", until canceled"
    return text if mission.rounds == 1 else f"{text}, {mission.rounds} rounds"


def mission_line(status: MissionStatusFrame) -> str:
    """One readable line for a mission's status."""
    if status.state == "none":
        return status.reason or "no mission"
    rounds = "" if status.rounds == 1 else f" round {status.round}/{status.rounds or 'inf'}"
    where = f"step {status.step}/{status.steps}{rounds}"
    text = f"{status.mission_id} {status.state}: {where} {status.kind}".rstrip()
    if status.event not in ("progress", ""):
        text += f" [{status.event}]"
    if status.distance_m is not None:
        text += f", {status.distance_m:.1f} m to go"
    if status.eta_s is not None:
        text += f", {status.eta_s:.0f} s"
    if status.message:
        text += f" - {status.message} (navd mission continue)"
    if status.reason:
        text += f" ({status.reason})"
    return text


def _run(args: argparse.Namespace) -> int:
    try:
        mission = load_mission(args.file, args.mission_id)
    except ConfigError as err:
        print(f"navd mission run: {err}", file=sys.stderr)
        return EXIT_USAGE
    try:
        with connect(args) as client:
            ack = client.request(mission)
            print(
                frame_text(ack)
                if args.json
                else f"mission {ack.mission_id} sent: {_size(mission)}",
                flush=True,
            )
            if not args.wait:
                return EXIT_OK
            # a subscriber is never idle (tcp.control_idle_timeout_s): a mission may run for
            # hours with no report between two steps
            client.request(SubscribeFrame(rate_hz=KEEP_ALIVE_HZ))
            last = _follow(client, ack.mission_id, raw=args.json)
    except (ClientError, ConfigError) as err:
        print(f"navd mission run: {err}", file=sys.stderr)
        return EXIT_FAILED
    except KeyboardInterrupt:
        print("\nnavd mission run: stopped following; the mission goes on", file=sys.stderr)
        return EXIT_FAILED
    if last.state == "failed":
        return EXIT_FAILED
    return EXIT_CANCELED if last.state == "canceled" else EXIT_OK


def _follow(client: Client, mission_id: str | None, *, raw: bool) -> MissionStatusFrame:
    """Print a line for each event of the mission until it ends (``raw``: its frame, as
    JSON); its last status."""
    client.timeout_s = None  # a patrol may run for hours
    client.sock.settimeout(None)
    shown = math.nan
    while True:
        status = client.receive_type(MissionStatusFrame)
        if status.mission_id != mission_id:
            continue
        if status.event == "progress":
            left = status.distance_m
            if left is None or (not math.isnan(shown) and abs(left - shown) < 1.0):
                continue  # a line for each metre driven, not for each planner tick
            shown = left
        print(frame_text(status) if raw else mission_line(status), flush=True)
        if status.state in ENDED:
            return status


def _status(args: argparse.Namespace) -> int:
    try:
        with connect(args) as client:
            client.request(SubscribeFrame(rate_hz=10))
            frame = client.receive_type(StatusFrame)
    except (ClientError, ConfigError) as err:
        print(f"navd mission status: {err}", file=sys.stderr)
        return EXIT_FAILED
    if frame.mission is None:
        print("no mission")
        return EXIT_OK
    print(mission_line(frame.mission))
    return EXIT_OK


def _control(args: argparse.Namespace) -> int:
    """Send the action; print how navd answered it (refused: exit 1)."""
    try:
        with connect(args) as client:
            client.request(MissionControlFrame(action=args.action))
            status = client.receive_type(MissionStatusFrame)
            while status.event == "progress":  # the drive's own reports, not the answer
                status = client.receive_type(MissionStatusFrame)
    except (ClientError, ConfigError) as err:
        print(f"navd mission {args.action}: {err}", file=sys.stderr)
        return EXIT_FAILED
    print(mission_line(status))
    return EXIT_FAILED if status.event == "refused" else EXIT_OK
