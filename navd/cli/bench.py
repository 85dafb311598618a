"""``navd bench NAME``: the benchmarks behind the performance figures."""

from __future__ import annotations

import argparse
import importlib.util
import sys

from navd.cli.common import EXIT_OK, EXIT_USAGE, Commands, print_figures

__all__ = ["add_commands"]


def add_commands(commands: Commands) -> None:
    """Add ``bench ingest|estimation|scan|planning|safety|order|compare|fleet``."""
    bench = commands.add_parser("bench", help="run a benchmark and print its figures")
    names = bench.add_subparsers(dest="bench_command", metavar="NAME", required=True)
    ingest = names.add_parser(
        "ingest", help="daemon CPU, loop lag and drops under full sensor load over TCP"
    )
    ingest.add_argument("--seconds", type=float, default=10.0, help="[s] streaming time")
    ingest.add_argument("--rays", type=int, default=1440, help="lidar rays per scan")
    ingest.add_argument("--binary", action="store_true", help="lidar ranges as base64 float32")
    ingest.add_argument(
        "--imu-batch", type=int, default=1, help="IMU lines per write (1: one per sample)"
    )
    ingest.add_argument(
        "--view",
        action="store_true",
        help="also the whole daemon with the live view off, and watched by a viewer of every "
        "channel (needs the websockets package, a development dependency)",
    )
    ingest.add_argument(
        "--lidar-program",
        type=int,
        default=0,
        metavar="POINTS",
        help="the lidar as an emulated LD06 of POINTS points per turn at 10 Hz on a "
        "pseudo-terminal, read by `navd sensor ld06` (its CPU use is reported)",
    )
    ingest.add_argument("--json", action="store_true", help="print JSON (default: readable)")
    ingest.set_defaults(handler=_ingest)
    estimation = names.add_parser(
        "estimation", help="Madgwick per sample, UKF per event, cost of a late event"
    )
    estimation.add_argument("--seconds", type=float, default=60.0, help="[s] synthetic drive")
    estimation.add_argument("--json", action="store_true", help="print JSON (default: readable)")
    estimation.set_defaults(handler=_estimation)
    scan = names.add_parser("scan", help="ms from a 720-ray scan to an updated pose")
    scan.add_argument("--scans", type=int, default=400, help="scans in the drive")
    scan.add_argument("--beams", type=int, default=720, help="rays per scan")
    scan.add_argument("--json", action="store_true", help="print JSON (default: readable)")
    scan.set_defaults(handler=_scan)
    fleet = names.add_parser(
        "fleet", help="navd fleet driving N lightweight VDA 5050 vehicles through mosquitto"
    )
    fleet.add_argument("--vehicles", type=int, default=50, help="how many (default 50)")
    fleet.add_argument("--json", action="store_true", help="print JSON (default: readable)")
    fleet.set_defaults(handler=_fleet)
    planning = names.add_parser("planning", help="A* on 1000² and 2000² grids, ms per DWA cycle")
    planning.add_argument("--repeats", type=int, default=5, help="A* searches per grid")
    planning.add_argument("--cycles", type=int, default=200, help="DWA cycles timed")
    planning.add_argument("--json", action="store_true", help="print JSON (default: readable)")
    planning.set_defaults(handler=_planning)
    safety = names.add_parser(
        "safety", help="ms from a lidar or IMU going silent or away to the wheels stopping"
    )
    safety.add_argument("--trials", type=int, default=10, help="trials of each case")
    safety.add_argument(
        "--lidar-program",
        choices=("ld06", "rplidar"),
        help="instead: `navd sensor KIND` on an emulated lidar at its baud rate and rhythm, "
        "the daemon driven by hand (stale events, safety holds, delivery, freeze to stop)",
    )
    safety.add_argument("--model", default="A1", help="--lidar-program rplidar: the model")
    safety.add_argument(
        "--seconds", type=float, default=60.0, help="--lidar-program: [s] measured driving"
    )
    safety.add_argument(
        "--busy", type=int, default=0, help="--lidar-program: CPU-bound processes beside it"
    )
    safety.add_argument("--json", action="store_true", help="print JSON (default: readable)")
    safety.set_defaults(handler=_safety)
    order = names.add_parser(
        "order", help="ms the largest VDA 5050 order holds the loop, read whole and in slices"
    )
    order.add_argument("--repeats", type=int, default=9, help="reads each way")
    order.add_argument("--json", action="store_true", help="print JSON (default: readable)")
    order.set_defaults(handler=_order)
    compare = names.add_parser(
        "compare", help="navd beside pyastar2d, imufusion, filterpy and kiss-icp: time ratios"
    )
    compare.add_argument("--repeats", type=int, default=9, help="timed runs of each search")
    compare.add_argument("--json", action="store_true", help="print JSON (default: readable)")
    compare.set_defaults(handler=_compare)


def _ingest(args: argparse.Namespace) -> int:
    from navd.bench import ingest  # noqa: PLC0415 - each benchmark imports what it times

    if args.view and importlib.util.find_spec("websockets") is None:
        print("--view needs the websockets package: pip install websockets", file=sys.stderr)
        return EXIT_USAGE
    figures = ingest.run(
        seconds=args.seconds,
        rays=args.rays,
        binary=args.binary,
        imu_batch=args.imu_batch,
        view=args.view,
        lidar_program=args.lidar_program,
    )
    print_figures(figures, args.json)
    return EXIT_OK


def _estimation(args: argparse.Namespace) -> int:
    from navd.bench import estimation  # noqa: PLC0415

    print_figures(estimation.run(seconds=args.seconds), args.json)
    return EXIT_OK


def _scan(args: argparse.Namespace) -> int:
    from navd.bench import scan  # noqa: PLC0415

    print_figures(scan.run(scans=args.scans, beams=args.beams), args.json)
    return EXIT_OK


def _order(args: argparse.Namespace) -> int:
    from navd.bench import order_reading  # noqa: PLC0415

    print_figures(order_reading.run(repeats=max(1, args.repeats)), args.json)
    return EXIT_OK


def _planning(args: argparse.Namespace) -> int:
    from navd.bench import planning  # noqa: PLC0415

    print_figures(planning.run(repeats=args.repeats, cycles=args.cycles), args.json)
    return EXIT_OK


def _fleet(args: argparse.Namespace) -> int:
    from navd.bench import fleet  # noqa: PLC0415
    from navd.sim import SimError  # noqa: PLC0415

    if args.vehicles < 1:
        print("navd bench fleet: --vehicles must be at least 1", file=sys.stderr)
        return EXIT_USAGE
    try:
        figures = fleet.run(vehicles=args.vehicles)
    except SimError as err:
        print(f"navd bench fleet: {err}", file=sys.stderr)
        return EXIT_USAGE
    print_figures(figures, args.json)
    return EXIT_OK


def _safety(args: argparse.Namespace) -> int:
    if args.lidar_program:
        from navd.bench import lidar_program  # noqa: PLC0415

        figures = lidar_program.run(
            args.lidar_program,
            seconds=args.seconds,
            busy=args.busy,
            model=args.model,
            freezes=args.trials,
        )
        print_figures(figures, args.json)
        return EXIT_OK
    from navd.bench import safety  # noqa: PLC0415

    print_figures(safety.run(trials=args.trials), args.json)
    return EXIT_OK


def _compare(args: argparse.Namespace) -> int:
    from navd.bench import compare  # noqa: PLC0415

    print_figures(compare.run(repeats=args.repeats), args.json)
    return EXIT_OK
