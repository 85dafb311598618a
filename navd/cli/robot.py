"""``navd pose set|find`` and ``navd map save|load``: telling the running daemon where the
robot is or having it search its map for it, having it save its map, or replacing its map
with a saved one."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable
from pathlib import Path
from typing import TypeVar

from pydantic import ValidationError

from navd.cli.common import EXIT_FAILED, EXIT_OK, EXIT_USAGE, Commands, connect, connection_options
from navd.config import ConfigError
from navd.wire import (
    ClientError,
    FindPoseFrame,
    Frame,
    InitialPoseFrame,
    LoadMapFrame,
    MapLoadedFrame,
    MapSavedFrame,
    PoseFoundFrame,
    ReplyPart,
    SaveMapFrame,
)

__all__ = ["add_commands"]

MAP_SAVE_TIMEOUT_S = 30.0  # [s] a large map takes a while to write
R = TypeVar("R", bound=ReplyPart)
FIND_TIMEOUT_S = 15.0  # [s] the search runs at the next scan: a lidar and a map are needed


def add_commands(commands: Commands) -> None:
    """Add ``pose set``, ``pose find``, ``map save`` and ``map load``."""
    pose = commands.add_parser("pose", help="tell the running daemon where the robot is")
    pose_actions = pose.add_subparsers(dest="pose_command", metavar="ACTION", required=True)
    pose_set = pose_actions.add_parser(
        "set", help="the robot's pose in the map: localization starts again from it"
    )
    pose_set.add_argument("x", type=float, help="[m] map x")
    pose_set.add_argument("y", type=float, help="[m] map y")
    pose_set.add_argument("yaw", type=float, help="[rad] heading, counter-clockwise from +x")
    pose_set.add_argument("--std-xy", type=float, default=0.5, help="[m] how sure, 1 sigma (0.5)")
    pose_set.add_argument(
        "--std-yaw", type=float, default=0.3, help="[rad] how sure of the heading (0.3)"
    )
    connection_options(pose_set)
    pose_set.set_defaults(handler=_pose_set)
    pose_find = pose_actions.add_parser(
        "find", help="search the whole map for the robot (lost, or moved by hand)"
    )
    connection_options(pose_find)
    pose_find.set_defaults(handler=_pose_find)

    maps = commands.add_parser("map", help="the running daemon's map")
    map_actions = maps.add_subparsers(dest="map_command", metavar="ACTION", required=True)
    save = map_actions.add_parser(
        "save", help="save the map now (ROS map_server .yaml and .pgm, and navd's state)"
    )
    save.add_argument(
        "name",
        nargs="?",
        default="",
        help="a name in slam.map_dir (default: slam.map_name), or a path: DIR/NAME.yaml "
        "(written by the daemon, on its machine; needs tcp.allow_privileged_changes)",
    )
    connection_options(save)
    save.set_defaults(handler=_map_save)
    load = map_actions.add_parser(
        "load",
        help="replace the map with a saved one from slam.map_dir (the robot is then "
        "searched for on it)",
    )
    load.add_argument(
        "name",
        help="the map's name in slam.map_dir (NAME), or a path to its DIR/NAME.yaml (read by "
        "the daemon; needs tcp.allow_privileged_changes)",
    )
    connection_options(load)
    load.set_defaults(handler=_map_load)


def _usage(command: str, err: ValidationError) -> int:
    problem = err.errors()[0]
    where = ".".join(str(p) for p in problem["loc"]) or command
    print(f"navd {command}: {where}: {problem['msg']}", file=sys.stderr)
    return EXIT_USAGE


def _pose_set(args: argparse.Namespace) -> int:
    try:
        frame = InitialPoseFrame(
            x=args.x, y=args.y, yaw=args.yaw, std_xy=args.std_xy, std_yaw=args.std_yaw
        )
    except ValidationError as err:
        return _usage("pose set", err)
    try:
        with connect(args) as client:
            client.request(frame)
    except (ClientError, ConfigError) as err:
        print(f"navd pose set: {err}", file=sys.stderr)
        return EXIT_FAILED
    print(f"pose set: ({args.x:.3f}, {args.y:.3f}) m, {args.yaw:.3f} rad")
    return EXIT_OK


def _ask(
    args: argparse.Namespace,
    frame: Frame,
    answer: type[R],
    wanted: Callable[[R], bool],
    timeout_s: float,
) -> R:
    """Send ``frame`` and wait up to ``timeout_s`` for the first ``answer`` frame that is
    ``wanted`` (the daemon's answers go to every control client).

    Raises:
        ClientError: navd cannot be reached, refused the request, or did not answer in time.
        ConfigError: the config file named by the options is bad.
    """
    with connect(args) as client:
        client.request(frame)
        client.timeout_s = timeout_s
        client.sock.settimeout(timeout_s)
        while True:
            reply: R = client.receive_type(answer)
            if wanted(reply):
                return reply


def _name_and_folder(text: str) -> tuple[str, str | None]:
    """A map's name, and its folder when ``text`` is a path (it has a folder or ends in
    .yaml) rather than a name in slam.map_dir; a relative path is from here."""
    if "/" not in text and not text.endswith(".yaml"):
        return text, None
    path = Path(text).expanduser().absolute()
    return path.name.removesuffix(".yaml"), str(path.parent)


def _map_save(args: argparse.Namespace) -> int:
    name, folder = _name_and_folder(args.name)
    try:
        frame = SaveMapFrame(name=name, folder=folder)
    except ValidationError as err:
        return _usage("map save", err)
    try:
        saved = _ask(
            args,
            frame,
            MapSavedFrame,
            lambda f: not name or f.name == name,
            MAP_SAVE_TIMEOUT_S,
        )
    except (ClientError, ConfigError) as err:
        print(f"navd map save: {err}", file=sys.stderr)
        return EXIT_FAILED
    if saved.reason:
        print(f"navd map save: {saved.name}: nothing written: {saved.reason}", file=sys.stderr)
        return EXIT_FAILED
    for file in saved.files or [saved.path]:
        print(f"wrote {file}")
    return EXIT_OK


def _map_load(args: argparse.Namespace) -> int:
    name, folder = _name_and_folder(args.name)
    try:
        frame = LoadMapFrame(name=name, folder=folder)
    except ValidationError as err:
        return _usage("map load", err)
    name = frame.name.removesuffix(".yaml")
    try:
        loaded = _ask(args, frame, MapLoadedFrame, lambda f: f.name == name, MAP_SAVE_TIMEOUT_S)
    except (ClientError, ConfigError) as err:
        print(f"navd map load: {err}", file=sys.stderr)
        return EXIT_FAILED
    if loaded.reason:
        print(f"navd map load: the map in use was kept: {loaded.reason}", file=sys.stderr)
        return EXIT_FAILED
    print(f"loaded {loaded.path}; the robot is searched for on it at the next scan")
    return EXIT_OK


def _pose_find(args: argparse.Namespace) -> int:
    try:
        found = _ask(args, FindPoseFrame(), PoseFoundFrame, lambda f: f.whole_map, FIND_TIMEOUT_S)
    except ConfigError as err:
        print(f"navd pose find: {err}", file=sys.stderr)
        return EXIT_FAILED
    except ClientError as err:
        print(
            f"navd pose find: {err}; navd searches at the next scan, on its map: is a lidar "
            "connected, and is there a map?",
            file=sys.stderr,
        )
        return EXIT_FAILED
    print(
        f"found at ({found.x:.3f}, {found.y:.3f}) m, {found.yaw:.3f} rad; "
        f"{found.score:.0%} of the scan on mapped obstacles"
    )
    return EXIT_OK
