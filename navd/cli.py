"""The ``navd`` command line: run the daemon, check and dump configs.

The only place in navd that prints and chooses exit codes.
Exit codes: 0 success, 1 the daemon failed at run time, 2 bad usage or bad config.
"""

from __future__ import annotations

import argparse
import asyncio
import dataclasses
import json
import math
import os
import sys
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from navd import __version__
from navd.config import ConfigError, NavdConfig, dump_toml, load_config
from navd.errors import NavdError
from navd.logs import configure_logging, get_logger

if TYPE_CHECKING:
    from navd.lifecycle import Daemon

__all__ = ["main"]

EXIT_OK = 0
EXIT_FAILED = 1
EXIT_USAGE = 2


def main(argv: Sequence[str] | None = None) -> int:
    """Run the navd command line with ``argv`` (default: sys.argv[1:]); returns the exit code."""
    parser = _parser()
    args = parser.parse_args(argv)
    if args.command is None:
        parser.print_help(sys.stderr)
        return EXIT_USAGE
    # Until `run` applies the config's logging section: warnings and errors, on stderr, so
    # that what a command prints on stdout (JSON figures, status) stays clean.
    configure_logging("warning", "auto")
    handler = args.handler
    code: int = handler(args)
    return code


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="navd", description=__doc__.splitlines()[0])
    parser.add_argument("--version", action="version", version=f"navd {__version__}")
    commands = parser.add_subparsers(dest="command", metavar="COMMAND")

    run = commands.add_parser("run", help="run the daemon")
    run.add_argument("--config", type=Path, help="TOML config file (default: built-in defaults)")
    run.set_defaults(handler=_cmd_run)

    config = commands.add_parser("config", help="check or dump a config file")
    config_commands = config.add_subparsers(dest="config_command", metavar="ACTION", required=True)
    check = config_commands.add_parser("check", help="validate a config file")
    check.add_argument("file", type=Path, help="TOML config file")
    check.set_defaults(handler=_cmd_config_check)
    dump = config_commands.add_parser(
        "dump", help="print the effective config as TOML, defaults filled in"
    )
    dump.add_argument("--config", type=Path, help="TOML config file (default: built-in defaults)")
    dump.add_argument(
        "--comments", action="store_true", help="describe every key (as in config/navd.toml)"
    )
    dump.set_defaults(handler=_cmd_config_dump)

    goal = commands.add_parser("goal", help="send a goal in the map frame")
    goal.add_argument("x", type=float, help="[m] map x")
    goal.add_argument("y", type=float, help="[m] map y")
    goal.add_argument("--yaw", type=float, help="[rad] final heading (default: any)")
    goal.add_argument("--id", dest="goal_id", help="goal id (default: chosen by navd)")
    _connection_options(goal)
    goal.set_defaults(handler=_cmd_goal)

    cancel = commands.add_parser("cancel", help="cancel the active goal")
    cancel.add_argument("--id", dest="goal_id", help="cancel only this goal")
    _connection_options(cancel)
    cancel.set_defaults(handler=_cmd_cancel)

    status = commands.add_parser("status", help="watch the daemon's status")
    status.add_argument("--rate", type=float, default=2.0, help="[Hz] updates per second")
    status.add_argument("--once", action="store_true", help="print one status and exit")
    status.add_argument("--json", action="store_true", help="print raw status frames")
    _connection_options(status)
    status.set_defaults(handler=_cmd_status)

    _bench_commands(commands)
    _slam_commands(commands)
    _sim_commands(commands)
    return parser


def _sim_commands(commands: Any) -> None:
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
    demo.set_defaults(handler=_cmd_demo)
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
    sim.set_defaults(handler=_cmd_sim)
    barn = commands.add_parser("barn", help="the BARN benchmark on navd's planner")
    barn.add_argument(
        "--dataset",
        type=Path,
        default=Path("../shared/datasets/barn"),
        help="folder with barn_cylinders.csv.gz and path_files/ (default ../shared/datasets/barn)",
    )
    barn.add_argument("--worlds", help="comma-separated world indices (default: all)")
    barn.add_argument("--json", action="store_true", help="print JSON (default: readable)")
    barn.set_defaults(handler=_cmd_barn)


def _bench_commands(commands: Any) -> None:
    bench = commands.add_parser("bench", help="run a benchmark and print its figures")
    bench_commands = bench.add_subparsers(dest="bench_command", metavar="NAME", required=True)
    ingest = bench_commands.add_parser(
        "ingest", help="daemon CPU, loop lag and drops under full sensor load over TCP"
    )
    ingest.add_argument("--seconds", type=float, default=10.0, help="[s] streaming time")
    ingest.add_argument("--rays", type=int, default=1440, help="lidar rays per scan")
    ingest.add_argument("--binary", action="store_true", help="lidar ranges as base64 float32")
    ingest.add_argument(
        "--imu-batch", type=int, default=1, help="IMU lines per write (1: one per sample)"
    )
    ingest.add_argument("--json", action="store_true", help="print JSON (default: readable)")
    ingest.set_defaults(handler=_cmd_bench_ingest)
    estimation = bench_commands.add_parser(
        "estimation", help="Madgwick per sample, UKF per event, cost of a late event"
    )
    estimation.add_argument("--seconds", type=float, default=60.0, help="[s] synthetic drive")
    estimation.add_argument("--json", action="store_true", help="print JSON (default: readable)")
    estimation.set_defaults(handler=_cmd_bench_estimation)
    scan = bench_commands.add_parser("scan", help="ms from a 720-ray scan to an updated pose")
    scan.add_argument("--scans", type=int, default=400, help="scans in the drive")
    scan.add_argument("--beams", type=int, default=720, help="rays per scan")
    scan.add_argument("--json", action="store_true", help="print JSON (default: readable)")
    scan.set_defaults(handler=_cmd_bench_scan)
    planning = bench_commands.add_parser(
        "planning", help="A* on 1000² and 2000² grids, ms per DWA cycle"
    )
    planning.add_argument("--repeats", type=int, default=5, help="A* searches per grid")
    planning.add_argument("--cycles", type=int, default=200, help="DWA cycles timed")
    planning.add_argument("--json", action="store_true", help="print JSON (default: readable)")
    planning.set_defaults(handler=_cmd_bench_planning)


def _slam_commands(commands: Any) -> None:
    replay = commands.add_parser("replay", help="run SLAM over a laser log, as fast as possible")
    replay.add_argument(
        "log",
        type=Path,
        help="<name>_scans.txt[.gz] dump, CARMEN .clf[.gz], ROS 1 .bag or ROS 2 bag folder",
    )
    replay.add_argument("--out", type=Path, required=True, help="folder for the results")
    replay.add_argument("--config", type=Path, help="TOML config (its slam section is used)")
    replay.add_argument("--laser-x", type=float, help="[m] lidar x on the robot (slam.laser_x_m)")
    replay.add_argument("--laser-y", type=float, help="[m] lidar y on the robot (slam.laser_y_m)")
    replay.add_argument(
        "--laser-yaw", type=float, help="[rad] lidar yaw on the robot (slam.laser_yaw_rad)"
    )
    replay.add_argument("--max-range", type=float, help="[m] longest range used (slam.max_range_m)")
    replay.add_argument(
        "--loop-closure", action="store_true", help="close loops (slam.loop_closure = true)"
    )
    replay.add_argument(
        "--scan-topic", help="bag topic of the scans (default: the sensor_msgs/LaserScan one)"
    )
    replay.add_argument(
        "--odom-topic", help="bag topic of the odometry (default: the nav_msgs/Odometry one)"
    )
    replay.add_argument(
        "--odometry",
        choices=("log", "scan", "none"),
        default="log",
        help="motion prior: the log's odometry (default), kiss-icp scan odometry, or none",
    )
    replay.add_argument("--quiet", action="store_true", help="no progress line")
    replay.set_defaults(handler=_cmd_replay)

    evaluate = commands.add_parser("eval", help="score results against ground truth")
    eval_commands = evaluate.add_subparsers(dest="eval_command", metavar="METRIC", required=True)
    relations = eval_commands.add_parser(
        "relations", help="Kümmerle et al. 2009 relation errors of a TUM trajectory"
    )
    relations.add_argument("trajectory", type=Path, help="TUM file (stamp x y z qx qy qz qw)")
    relations.add_argument("relations", type=Path, help=".relations file (t1 t2 x y z r p y)")
    relations.add_argument("--json", action="store_true", help="print JSON (default: readable)")
    relations.set_defaults(handler=_cmd_eval_relations)


def _connection_options(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--config", type=Path, help="take host, port and token from this file")
    parser.add_argument("--host", help="navd address (default: tcp.host, 127.0.0.1)")
    parser.add_argument("--port", type=int, help="navd port (default: tcp.port, 7420)")
    parser.add_argument("--token", help="shared secret (default: tcp.token or $NAVD_TOKEN)")


def _connect(args: argparse.Namespace) -> Any:
    from navd.drivers.client import Client  # noqa: PLC0415 - only the client commands need it

    tcp = _load(args.config).tcp
    host = args.host or ("127.0.0.1" if tcp.host in ("0.0.0.0", "::") else tcp.host)
    token = args.token or tcp.token or os.environ.get("NAVD_TOKEN")
    return Client(host, args.port or tcp.port, device_id=f"cli-{os.getpid()}", token=token)


def _load(path: Path | None) -> NavdConfig:
    return NavdConfig() if path is None else load_config(path)


def _cmd_config_check(args: argparse.Namespace) -> int:
    try:
        load_config(args.file)
    except ConfigError as err:
        print(err, file=sys.stderr)
        return EXIT_USAGE
    print(f"{args.file}: ok")
    return EXIT_OK


def _cmd_config_dump(args: argparse.Namespace) -> int:
    try:
        config = _load(args.config)
    except ConfigError as err:
        print(err, file=sys.stderr)
        return EXIT_USAGE
    sys.stdout.write(dump_toml(config, comments=args.comments))
    return EXIT_OK


def _cmd_run(args: argparse.Namespace) -> int:
    try:
        config = _load(args.config)
    except ConfigError as err:
        print(err, file=sys.stderr)
        return EXIT_USAGE
    configure_logging(config.logging.level, config.logging.format)
    from navd.app import build_modules  # noqa: PLC0415 - keep `navd config` fast to start
    from navd.lifecycle import Daemon  # noqa: PLC0415

    daemon = Daemon(config, build_modules(config), config_path=args.config)
    try:
        if config.lifecycle.event_loop == "uvloop":
            import uvloop  # noqa: PLC0415

            uvloop.run(daemon.run())
        else:
            asyncio.run(daemon.run())
    except NavdError as err:
        get_logger("cli").error("daemon_failed", error=str(err))
        return _exit_past_threads(daemon, EXIT_FAILED)
    return _exit_past_threads(daemon, EXIT_OK)


def _exit_past_threads(daemon: Daemon, code: int) -> int:
    """Return ``code``, or end the process at once with it if a set-up thread (a kernel
    compiling) is still running: the daemon has stopped cleanly and its files are written,
    and letting the interpreter shut down under a running compiler can abort the process."""
    unfinished = daemon.workers.unfinished_threads()
    if unfinished:
        get_logger("cli").info("exit_without_waiting", threads=unfinished)
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(code)
    return code


def _client_command(args: argparse.Namespace, frame: dict[str, Any]) -> int:
    from navd.drivers.client import ClientError  # noqa: PLC0415

    try:
        with _connect(args) as client:
            ack = client.request(frame)
    except (ClientError, ConfigError) as err:
        print(f"navd {frame['type']}: {err}", file=sys.stderr)
        return EXIT_FAILED
    print(json.dumps(ack))
    return EXIT_OK


def _cmd_goal(args: argparse.Namespace) -> int:
    frame: dict[str, Any] = {"type": "goal", "x": args.x, "y": args.y}
    if args.yaw is not None:
        frame["yaw"] = args.yaw
    if args.goal_id is not None:
        frame["goal_id"] = args.goal_id
    return _client_command(args, frame)


def _cmd_cancel(args: argparse.Namespace) -> int:
    frame: dict[str, Any] = {"type": "cancel"}
    if args.goal_id is not None:
        frame["goal_id"] = args.goal_id
    return _client_command(args, frame)


def _cmd_status(args: argparse.Namespace) -> int:
    from navd.drivers.client import ClientError  # noqa: PLC0415

    try:
        with _connect(args) as client:
            client.request({"type": "subscribe", "rate_hz": args.rate})
            while True:
                frame = client.receive()
                if frame.get("type") != "status":
                    continue
                print(json.dumps(frame) if args.json else format_status(frame), flush=True)
                if args.once:
                    return EXIT_OK
    except (ClientError, ConfigError) as err:
        print(f"navd status: {err}", file=sys.stderr)
        return EXIT_FAILED
    except KeyboardInterrupt:
        return EXIT_OK


def format_status(frame: dict[str, Any]) -> str:
    """One readable line for a status frame."""
    pose = frame.get("pose")
    where = (
        f"pose ({pose['x']:.2f}, {pose['y']:.2f}) m {math.degrees(pose['yaw']):.0f} deg"
        if pose
        else "pose unknown"
    )
    vel = frame.get("velocity")
    moving = f"v {vel['linear']:.2f} m/s w {vel['angular']:.2f} rad/s" if vel else "v -"
    goal = frame.get("goal")
    target = f"goal {goal['goal_id']} {goal['state']}" if goal else "no goal"
    devices = (
        ", ".join(
            f"{d['device_id']}({d['kind']}{', STALE' if d['stale'] else ''})"
            for d in frame.get("devices", [])
        )
        or "none"
    )
    diag = frame.get("diagnostics", {})
    lag = diag.get("loop_lag_p99_ms")
    safety = "; ".join(diag.get("safety", [])) or "ok"
    lag_text = f"{lag:.2f} ms" if lag is not None else "-"
    return (
        f"[{frame.get('mode', '?')}] {where} | {moving} | {target} | devices: {devices} | "
        f"lag p99 {lag_text} | safety: {safety}"
    )


def _print_figures(figures: Mapping[str, object], as_json: bool) -> None:
    if as_json:
        print(json.dumps(figures, indent=2))
    else:
        for key, value in figures.items():
            print(f"{key:>34}: {value}")


def _cmd_replay(args: argparse.Namespace) -> int:
    from navd.slam.bags import inspect_bag, is_bag, read_bag  # noqa: PLC0415
    from navd.slam.errors import SlamError  # noqa: PLC0415 - only replay needs SLAM
    from navd.slam.logfiles import count_scans, open_log  # noqa: PLC0415
    from navd.slam.pose import Pose2  # noqa: PLC0415
    from navd.slam.replay import replay  # noqa: PLC0415
    from navd.slam.settings import mapper_settings  # noqa: PLC0415

    slam = _load(args.config).slam
    settings = mapper_settings(slam)
    if args.max_range is not None:
        settings = dataclasses.replace(settings, max_range_m=args.max_range)
    if args.loop_closure:
        settings = dataclasses.replace(settings, loop_closure=True)
    mount = Pose2(slam.laser_x_m, slam.laser_y_m, slam.laser_yaw_rad)
    try:
        if is_bag(args.log):
            bag = inspect_bag(args.log, scan_topic=args.scan_topic, odom_topic=args.odom_topic)
            if bag.mount is not None:  # the recording's own transforms beat the config's
                mount = bag.mount
                if not args.quiet:
                    print(
                        f"laser mount from the bag's /tf_static: x {mount.x:.3f} m, "
                        f"y {mount.y:.3f} m, yaw {mount.yaw:.4f} rad",
                        file=sys.stderr,
                    )
            scans, total = read_bag(bag), bag.scans
        else:
            scans, total = open_log(args.log), count_scans(args.log)
        mount = Pose2(
            mount.x if args.laser_x is None else args.laser_x,
            mount.y if args.laser_y is None else args.laser_y,
            mount.yaw if args.laser_yaw is None else args.laser_yaw,
        )
        progress = None if args.quiet else _progress_line(total)
        result = replay(
            scans,
            args.out,
            settings,
            mount=mount,
            min_range_m=slam.min_range_m,
            odometry=args.odometry,
            progress=progress,
        )
    except SlamError as err:
        print(f"navd replay: {err}", file=sys.stderr)
        return EXIT_USAGE
    except OSError as err:
        print(f"navd replay: {err}", file=sys.stderr)
        return EXIT_FAILED
    if not args.quiet:
        print(file=sys.stderr)
    print(json.dumps(result.summary, indent=2))
    return EXIT_OK


def _progress_line(total: int) -> Callable[[int, float], None]:
    step = max(1, total // 200)

    def show(done: int, seconds: float) -> None:
        if done % step and done != total:
            return
        width = 30
        filled = width * done // max(total, 1)
        rate = seconds / max(done, 1) * 1e3
        sys.stderr.write(
            f"\r[{'#' * filled}{'.' * (width - filled)}] {done}/{total} scans, {rate:.1f} ms/scan"
        )
        sys.stderr.flush()

    return show


def _cmd_eval_relations(args: argparse.Namespace) -> int:
    from navd.slam.errors import SlamError  # noqa: PLC0415
    from navd.slam.relations import evaluate, read_relations, read_tum  # noqa: PLC0415

    try:
        stamps, poses = read_tum(args.trajectory)
        errors = evaluate(stamps, poses, read_relations(args.relations))
    except SlamError as err:
        print(f"navd eval relations: {err}", file=sys.stderr)
        return EXIT_USAGE
    except OSError as err:
        print(f"navd eval relations: {err}", file=sys.stderr)
        return EXIT_USAGE
    _print_figures(errors.as_dict(), args.json)
    return EXIT_OK if errors.used else EXIT_FAILED


def _cmd_bench_scan(args: argparse.Namespace) -> int:
    from navd.bench.scan import run  # noqa: PLC0415

    _print_figures(run(scans=args.scans, beams=args.beams), args.json)
    return EXIT_OK


def _cmd_demo(args: argparse.Namespace) -> int:
    from navd.sim.demo import run_demo  # noqa: PLC0415
    from navd.sim.errors import SimError  # noqa: PLC0415
    from navd.sim.world import load_world, office  # noqa: PLC0415

    try:
        world = office() if args.world is None else load_world(args.world)
        summary = run_demo(world, args.out, limit_s=args.limit, lockstep=not args.real_time)
    except SimError as err:
        print(f"navd demo: {err}", file=sys.stderr)
        return EXIT_USAGE
    print(json.dumps(summary, indent=2))
    print(
        f"navd demo: wrote {args.out / 'demo.png'} and {args.out / 'summary.json'}", file=sys.stderr
    )
    return EXIT_OK if summary["reached"] else EXIT_FAILED


def _cmd_sim(args: argparse.Namespace) -> int:
    from navd.sim.errors import SimError  # noqa: PLC0415
    from navd.sim.standalone import run_sim  # noqa: PLC0415
    from navd.sim.world import load_world, office  # noqa: PLC0415

    try:
        config = load_config(args.config)
    except ConfigError as err:
        print(f"navd sim: {err}", file=sys.stderr)
        return EXIT_USAGE
    try:
        world = office() if args.world is None else load_world(args.world)
        summary = run_sim(world, config, seed=args.seed, truth_path=args.truth, limit_s=args.limit)
    except SimError as err:
        print(f"navd sim: {err}", file=sys.stderr)
        return EXIT_FAILED
    print(json.dumps(summary, indent=2))
    return EXIT_OK


def _cmd_barn(args: argparse.Namespace) -> int:
    from navd.sim.barn import run_barn  # noqa: PLC0415
    from navd.sim.errors import SimError  # noqa: PLC0415

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
    _print_figures(summary, args.json)
    return EXIT_OK


def _cmd_bench_planning(args: argparse.Namespace) -> int:
    from navd.bench.planning import run  # noqa: PLC0415

    _print_figures(run(repeats=args.repeats, cycles=args.cycles), args.json)
    return EXIT_OK


def _cmd_bench_estimation(args: argparse.Namespace) -> int:
    from navd.bench.estimation import run  # noqa: PLC0415

    _print_figures(run(seconds=args.seconds), args.json)
    return EXIT_OK


def _cmd_bench_ingest(args: argparse.Namespace) -> int:
    from navd.bench.ingest import run  # noqa: PLC0415

    figures = run(
        seconds=args.seconds, rays=args.rays, binary=args.binary, imu_batch=args.imu_batch
    )
    _print_figures(figures, args.json)
    return EXIT_OK
