"""``navd fleet status|goal``: a small fleet control for navd vehicles (VDA 5050 over MQTT),
run from any machine that reaches the broker."""

from __future__ import annotations

import argparse
import asyncio
import json
import math
import sys
from pathlib import Path
from typing import Any

from navd.cli.common import EXIT_FAILED, EXIT_OK, EXIT_USAGE, Commands

__all__ = ["add_commands"]

DEFAULT_BROKER = "mqtt://127.0.0.1:1883"
# [m] as navd.fleetctl.group_map.DEFAULT_RADIUS_M (not imported: the parser stays light)
DEFAULT_RADIUS_M = 0.3


def add_commands(commands: Commands) -> None:
    """Add ``fleet``."""
    fleet = commands.add_parser(
        "fleet", help="drive a group of navd vehicles over VDA 5050 (docs/fleet.md)"
    )
    actions = fleet.add_subparsers(dest="fleet_command", metavar="ACTION", required=True)
    status = actions.add_parser("status", help="list the vehicles on the broker")
    _broker_options(status)
    status.set_defaults(handler=_status)
    goal = actions.add_parser(
        "goal", help="send the group's centre to X Y in a formation, all starting together"
    )
    goal.add_argument("x", type=float, help="[m] the group centre's goal x (map frame)")
    goal.add_argument("y", type=float, help="[m] the group centre's goal y")
    goal.add_argument(
        "--heading", type=float, default=None, help="[rad] the formation's heading there"
    )
    goal.add_argument(
        "--formation", choices=("line", "column", "triangle"), default="triangle", help="the shape"
    )
    goal.add_argument(
        "--spacing", type=float, default=1.5, help="[m] between neighbours (default 1.5)"
    )
    goal.add_argument(
        "--step",
        type=float,
        default=1.5,
        help="[m] released at a time (default 1.5; a column goes half its spacing at a time)",
    )
    goal.add_argument(
        "--speed", type=float, default=0.3, help="[m/s] the group's top speed (default 0.3)"
    )
    goal.add_argument(
        "--map",
        type=Path,
        default=None,
        help="the map the robots drive on (map .yaml): the group goes round walls, in a column "
        "through doors and corridors too narrow for its formation (default: straight, open "
        "ground)",
    )
    goal.add_argument(
        "--map-id",
        default=None,
        help="the map the robots must say they are on (their slam.map_name); robots on "
        "different maps are refused in any case",
    )
    goal.add_argument(
        "--radius",
        type=float,
        default=DEFAULT_RADIUS_M,
        help=f"[m] a robot's radius plus the margin it keeps from walls, for --map (default "
        f"{DEFAULT_RADIUS_M:g}: navd's 0.2 m disc and 0.1 m stop distance)",
    )
    goal.add_argument(
        "--robots", default=None, help="serial numbers, comma separated (default: all online)"
    )
    goal.add_argument(
        "--timeout", type=float, default=600.0, help="[s] give up after (default 600)"
    )
    _broker_options(goal)
    goal.set_defaults(handler=_goal)


def _broker_options(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--broker", default=DEFAULT_BROKER, help=f"the MQTT broker (default {DEFAULT_BROKER})"
    )
    parser.add_argument(
        "--interface", default="uagv", help="the topics' interface name (default uagv)"
    )


def _status(args: argparse.Namespace) -> int:
    from navd.fleetctl import fleet_view  # noqa: PLC0415 - MQTT only for this command

    try:
        view = asyncio.run(fleet_view(args.broker, args.interface))
    except (OSError, ValueError) as err:
        print(f"navd fleet: cannot read the broker {args.broker}: {err}", file=sys.stderr)
        return EXIT_FAILED
    except Exception as err:  # the MQTT client's own errors name the broker's refusal
        print(f"navd fleet: broker {args.broker}: {err}", file=sys.stderr)
        return EXIT_FAILED
    rows = []
    for vehicle in sorted(view.vehicles.values(), key=lambda v: v.name):
        state: dict[str, Any] = vehicle.state or {}
        position = vehicle.position
        rows.append(
            {
                "vehicle": vehicle.name,
                "connection": vehicle.connection,
                "x": None if position is None else round(position[0], 3),
                "y": None if position is None else round(position[1], 3),
                "order": state.get("orderId") or None,
                "last_node": state.get("lastNodeId") or None,
                "driving": state.get("driving"),
                "errors": [e.get("errorType") for e in state.get("errors", [])],
            }
        )
    print(json.dumps({"broker": args.broker, "vehicles": rows}, indent=2))
    return EXIT_OK


def _goal(args: argparse.Namespace) -> int:
    from navd.fleetctl import (  # noqa: PLC0415
        GroupGoal,
        GroupMap,
        drive_group,
    )
    from navd.slam import MapFileError  # noqa: PLC0415

    numbers = (args.x, args.y, args.spacing, args.step, args.speed, args.timeout, args.radius)
    numbers += () if args.heading is None else (args.heading,)
    positive = (args.spacing, args.step, args.speed, args.radius)
    if not all(math.isfinite(v) for v in numbers) or min(positive) <= 0:
        print(
            "navd fleet goal: x, y and heading must be finite; spacing, step, speed and radius > 0",
            file=sys.stderr,
        )
        return EXIT_USAGE
    group_map = None
    if args.map is not None:
        try:
            group_map = GroupMap.load(args.map, args.radius)
        except MapFileError as err:
            print(f"navd fleet goal: --map: {err}", file=sys.stderr)
            return EXIT_USAGE
    goal = GroupGoal(
        args.x,
        args.y,
        heading_rad=args.heading,
        formation=args.formation,
        spacing_m=args.spacing,
        step_m=args.step,
        speed_mps=args.speed,
    )
    serials = None if args.robots is None else [s for s in args.robots.split(",") if s]

    def report(event: dict[str, Any]) -> None:
        print(json.dumps(event), file=sys.stderr, flush=True)

    try:
        summary = asyncio.run(
            drive_group(
                args.broker,
                goal,
                serials=serials,
                interface=args.interface,
                timeout_s=args.timeout,
                report=report,
                group_map=group_map,
                map_id=args.map_id,
            )
        )
    except ValueError as err:
        print(f"navd fleet goal: {err}", file=sys.stderr)
        return EXIT_FAILED
    except Exception as err:  # the MQTT client's own errors name the broker's refusal
        print(f"navd fleet goal: broker {args.broker}: {err}", file=sys.stderr)
        return EXIT_FAILED
    print(json.dumps(summary))
    return EXIT_OK if summary["reached"] else EXIT_FAILED
