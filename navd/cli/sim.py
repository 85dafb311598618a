"""``navd demo|sim|barn``: the simulated robot with the daemon, beside it, or on BARN."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from navd.cli.common import EXIT_FAILED, EXIT_OK, EXIT_USAGE, Commands, print_figures
from navd.config import ConfigError, load_config

__all__ = ["add_commands"]


def add_commands(commands: Commands) -> None:
    """Add ``demo``, ``sim`` and ``barn``."""
    demo = commands.add_parser(
        "demo", help="the daemon drives a simulated robot to a goal; writes demo.png, summary.json"
    )
    demo.add_argument("--out", type=Path, default=Path("."), help="folder for the results (.)")
    demo.add_argument("--world", type=Path, help="world TOML or map .yaml (default: the office)")
    demo.add_argument("--limit", type=float, default=180.0, help="[s] give up after this long")
    demo.add_argument(
        "--real-time",
        action="store_true",
        help="run in real time (default: simulated time in lockstep, as fast as the CPU allows)",
    )
    demo.add_argument(
        "--view",
        action="store_true",
        help="serve the operator page and watch the drive in a browser (real time; the robot "
        "then waits for goals from the page until Ctrl-C)",
    )
    demo.add_argument(
        "--port",
        type=_port,
        default=0,
        metavar="P",
        help="with --view: the live view's WebSocket port, for Foxglove (default: a free one)",
    )
    demo.add_argument(
        "--page-port",
        type=_port,
        default=0,
        metavar="Q",
        help="with --view: the operator page's port (default: a free one)",
    )
    demo.add_argument(
        "--record", type=Path, metavar="DIR", help="record the drive to MCAP files in DIR"
    )
    demo.add_argument(
        "--fleet",
        type=int,
        metavar="N",
        help="N robots (each its own navd) on a local mosquitto drive a triangle to a group "
        "goal; writes fleet.png and fleet_summary.json (real time)",
    )
    demo.set_defaults(handler=_demo)
    sim = commands.add_parser(
        "sim", help="play a simulated robot for a running navd (its config names the ports)"
    )
    sim.add_argument(
        "--config", type=Path, required=True, help="the config file `navd run` was started with"
    )
    sim.add_argument("--world", type=Path, help="world TOML or map .yaml (default: the office)")
    sim.add_argument("--seed", type=int, default=0, help="seeds every noise source (0)")
    sim.add_argument("--truth", type=Path, help="write the ground truth CSV here at the end")
    sim.add_argument("--limit", type=float, help="[s] stop after this much simulated time")
    sim.set_defaults(handler=_sim)
    barn = commands.add_parser("barn", help="the BARN benchmark on navd's planner")
    barn.add_argument(
        "--dataset",
        type=Path,
        default=Path("../shared/datasets/barn"),
        help="folder with barn_cylinders.csv.gz and path_files/ (default ../shared/datasets/barn)",
    )
    barn.add_argument("--worlds", help="comma-separated world indices (default: all)")
    barn.add_argument("--json", action="store_true", help="print JSON (default: readable)")
    barn.set_defaults(handler=_barn)


def _port(text: str) -> int:
    """A TCP port, 1 to 65535."""
    try:
        port = int(text)
    except ValueError:
        port = 0
    if not 1 <= port <= 65535:
        raise argparse.ArgumentTypeError(f"{text!r} is not a port (1 to 65535)")
    return port


def _demo(args: argparse.Namespace) -> int:
    from navd.sim import (  # noqa: PLC0415
        SimError,
        load_world,
        office,
        run_demo,
    )

    if (args.port or args.page_port) and not args.view:
        print("navd demo: --port and --page-port need --view (they are its ports)", file=sys.stderr)
        return EXIT_USAGE
    if args.fleet is not None:
        return _fleet_demo(args)

    try:
        world = office() if args.world is None else load_world(args.world)
        summary = run_demo(
            world,
            args.out,
            limit_s=args.limit,
            lockstep=not args.real_time,
            view=args.view,
            view_port=args.port,
            page_port=args.page_port,
            record=args.record,
        )
    except SimError as err:
        print(f"navd demo: {err}", file=sys.stderr)
        return EXIT_USAGE
    print(json.dumps(summary, indent=2))
    wrote = ", ".join(str(args.out / name) for name in ("demo.png", "summary.json"))
    print(f"navd demo: wrote {wrote} and {args.out / 'demo.log'} (navd's log)", file=sys.stderr)
    return EXIT_OK if summary["reached"] else EXIT_FAILED


def _fleet_demo(args: argparse.Namespace) -> int:
    from navd.sim import (  # noqa: PLC0415
        SimError,
        run_fleet_demo,
    )

    if args.world is not None or args.view or args.record is not None:
        print(
            "navd demo --fleet: runs in its own world (the office, or a hall for more than "
            "three robots); drop --world, --view and --record",
            file=sys.stderr,
        )
        return EXIT_USAGE
    try:
        summary = run_fleet_demo(args.fleet, args.out, limit_s=max(args.limit, 300.0))
    except SimError as err:
        print(f"navd demo: {err}", file=sys.stderr)
        return EXIT_USAGE
    print(json.dumps(summary, indent=2))
    print(
        f"navd demo: wrote {args.out / 'fleet.png'} and {args.out / 'fleet_summary.json'}",
        file=sys.stderr,
    )
    return EXIT_OK if summary["reached"] and summary["collisions"] == 0 else EXIT_FAILED


def _sim(args: argparse.Namespace) -> int:
    from navd.sim import (  # noqa: PLC0415
        SimError,
        load_world,
        office,
        run_sim,
    )

    try:
        config = load_config(args.config)
    except ConfigError as err:
        print(f"navd sim: {err}", file=sys.stderr)
        return EXIT_USAGE
    try:
        world = office() if args.world is None else load_world(args.world)
        summary = run_sim(
            world,
            config,
            seed=args.seed,
            truth_path=args.truth,
            limit_s=args.limit,
            waiting=lambda what: print(
                f"navd sim: {what}; is `navd run --config {args.config}` running? "
                "(the sensors keep trying)",
                file=sys.stderr,
                flush=True,
            ),
        )
    except SimError as err:
        print(f"navd sim: {err}", file=sys.stderr)
        return EXIT_FAILED
    print(json.dumps(summary, indent=2))
    if not summary["sensors_connected"]:
        print(
            f"navd sim: navd at {summary['navd_address']} never answered: nothing was "
            "simulated for it",
            file=sys.stderr,
        )
        return EXIT_FAILED
    return EXIT_OK


def _barn(args: argparse.Namespace) -> int:
    from navd.sim import (  # noqa: PLC0415
        SimError,
        run_barn,
    )

    try:
        worlds = None if args.worlds is None else [int(w) for w in args.worlds.split(",")]
    except ValueError:
        print(
            f"navd barn: --worlds must be integers separated by commas, got {args.worlds!r}",
            file=sys.stderr,
        )
        return EXIT_USAGE
    try:
        summary = run_barn(args.dataset, worlds=worlds)
    except SimError as err:
        print(f"navd barn: {err}", file=sys.stderr)
        return EXIT_USAGE
    print_figures(summary, args.json)
    return EXIT_OK
