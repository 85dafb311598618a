"""``navd replay`` and ``navd eval``: SLAM over a recording, and scoring a trajectory."""

from __future__ import annotations

import argparse
import dataclasses
import itertools
import json
import sys
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import TYPE_CHECKING

from navd.cli.common import EXIT_FAILED, EXIT_OK, EXIT_USAGE, Commands, load, print_figures
from navd.cli.perturb_suite import add_suite_command
from navd.config import ConfigError

if TYPE_CHECKING:
    from navd.offline import LogScan
    from navd.slam import MapperSettings

__all__ = ["add_commands"]


def add_commands(commands: Commands) -> None:
    """Add ``replay``, ``eval relations`` and ``eval perturb``."""
    replay = commands.add_parser(
        "replay",
        help="play a navd recording through the whole pipeline, or run SLAM over a laser log",
    )
    replay.add_argument(
        "log",
        type=Path,
        help="a navd recording (.mcap file, or a folder of them), or a laser log: "
        "<name>_scans.txt[.gz] dump, CARMEN .clf[.gz], ROS 1 .bag or ROS 2 bag folder",
    )
    replay.add_argument(
        "--out", type=Path, help="folder for the results (required for a laser log)"
    )
    replay.add_argument(
        "--session", help="a navd recording: which session of the folder (default: its only one)"
    )
    replay.add_argument("--config", type=Path, help="TOML config (its slam and lidar sections)")
    replay.add_argument("--laser-x", type=float, help="[m] lidar x on the robot (lidar.x_m)")
    replay.add_argument("--laser-y", type=float, help="[m] lidar y on the robot (lidar.y_m)")
    replay.add_argument(
        "--laser-yaw", type=float, help="[rad] lidar yaw on the robot (lidar.yaw_rad)"
    )
    replay.add_argument("--max-range", type=float, help="[m] longest range used (slam.max_range_m)")
    replay.add_argument(
        "--loop-closure",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="close loops or not (slam.loop_closure; on by default)",
    )
    replay.add_argument(
        "--fine-resolution",
        type=float,
        metavar="M",
        help="[m] cell of the fine map each reported pose is refined on (default: half of "
        "slam.resolution_m; slam.resolution_m itself: no refinement)",
    )
    replay.add_argument(
        "--perturb",
        metavar="KIND",
        help="replay a seeded, worse version of the log: drop, every2, every3, odometry, "
        "odometry_spikes, noise, half_beams, fov120, range8 or spurious, or several joined by "
        "'+' (robustness checks, docs/slam.md)",
    )
    replay.add_argument("--seed", type=int, default=0, help="seed of --perturb (default 0)")
    replay.add_argument(
        "--map",
        type=Path,
        metavar="YAML",
        help="a saved map to go on mapping (its pose graph too, if saved with it; the robot "
        "is found on it by the first scan)",
    )
    replay.add_argument(
        "--scans",
        metavar="FROM:TO",
        help="only the scans FROM (counted from 0) up to but not including TO; either may be "
        "left out (a log split in two: 0:3000, then 3000:)",
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
        help="motion prior: the log's odometry (default), scan odometry (ICP), or none",
    )
    replay.add_argument("--quiet", action="store_true", help="no progress line")
    replay.set_defaults(handler=_replay)

    evaluate = commands.add_parser("eval", help="score results against ground truth")
    metrics = evaluate.add_subparsers(dest="eval_command", metavar="METRIC", required=True)
    relations = metrics.add_parser(
        "relations", help="Kümmerle et al. 2009 relation errors of a TUM trajectory"
    )
    relations.add_argument("trajectory", type=Path, help="TUM file (stamp x y z qx qy qz qw)")
    relations.add_argument("relations", type=Path, help=".relations file (t1 t2 x y z r p y)")
    relations.add_argument("--json", action="store_true", help="print JSON (default: readable)")
    relations.set_defaults(handler=_relations)
    add_suite_command(metrics)


def _is_navd_recording(path: Path) -> bool:
    return path.suffix == ".mcap" or (path.is_dir() and any(path.glob("*.mcap")))


def _load_kernels() -> None:
    """Every SLAM kernel loaded before the first scan, then what loading them left resident
    handed back, as the daemon does after its warm-ups: LLVM's code (some 70 MB that no scan
    runs) and the heap it freed. A child process fills numba's cache first with whatever the
    warm-ups call that it lacks, as the daemon's start does on a cold cache: compiling in
    this process would raise its peak (docs/slam.md has the figures)."""
    from navd.kernels import KernelCache  # noqa: PLC0415 - only replay needs it
    from navd.lifecycle import release_compiler_code, release_freed_memory  # noqa: PLC0415
    from navd.offline import warm_up  # noqa: PLC0415

    KernelCache().prepare(every_signature=True)
    warm_up()
    release_freed_memory()
    release_compiler_code()


def _mapper_settings(args: argparse.Namespace, settings: MapperSettings) -> MapperSettings:
    """The config's mapper settings with the replay's own options.

    Raises:
        ValueError: ``--fine-resolution`` out of its range (named).
    """
    if args.max_range is not None:
        settings = dataclasses.replace(settings, max_range_m=args.max_range)
    if args.loop_closure is not None:
        settings = dataclasses.replace(settings, loop_closure=args.loop_closure)
    fine = args.fine_resolution
    if fine is not None and not 0.005 <= fine <= settings.resolution_m:
        raise ValueError(
            f"--fine-resolution {fine}: must be at least 0.005 m and at most the map's cell, "
            f"slam.resolution_m ({settings.resolution_m} m)"
        )
    if fine is not None and fine < settings.resolution_m and not settings.loop_closure:
        raise ValueError(
            f"--fine-resolution {fine}: the fine map is drawn from the keyframes' scans, which "
            "only loop closure keeps; turn loop closure on, or leave --fine-resolution out"
        )
    return settings


def _replay(args: argparse.Namespace) -> int:
    if not args.log.exists():
        print(f"navd replay: {args.log}: no such file or folder", file=sys.stderr)
        return EXIT_USAGE
    if _is_navd_recording(args.log):
        return _play(args)
    if args.out is None:
        print(
            f"navd replay: {args.log} is not a navd recording (a .mcap file or a folder of "
            f"them); to run SLAM over a laser log or bag, give --out DIR",
            file=sys.stderr,
        )
        return EXIT_USAGE
    from navd.geometry import LidarMount  # noqa: PLC0415 - only replay needs SLAM
    from navd.offline import (  # noqa: PLC0415
        LogFormatError,
        OfflineError,
        open_recording,
        replay,
        replay_mount,
    )
    from navd.slam import (  # noqa: PLC0415
        MapperSettings,
        SlamError,
        load_map_state,
    )

    try:
        config = load(args.config)
    except ConfigError as err:
        print(f"navd replay: {err}", file=sys.stderr)
        return EXIT_USAGE
    try:
        settings = _mapper_settings(args, MapperSettings.from_config(config))
    except ValueError as err:
        print(f"navd replay: {err}", file=sys.stderr)
        return EXIT_USAGE
    try:
        start_map = None if args.map is None else load_map_state(args.map)
    except SlamError as err:
        print(f"navd replay: --map: {err}", file=sys.stderr)
        return EXIT_USAGE
    try:
        recording = open_recording(args.log, scan_topic=args.scan_topic, odom_topic=args.odom_topic)
        if recording.mount is not None and not args.quiet:
            m = recording.mount
            print(
                f"laser mount from the recording: x {m.x:.3f} m, y {m.y:.3f} m, "
                f"yaw {m.yaw:.4f} rad",
                file=sys.stderr,
            )
        mount = replay_mount(
            LidarMount.of(config.lidar),
            recording.mount,
            x_m=args.laser_x,
            y_m=args.laser_y,
            yaw_rad=args.laser_yaw,
        )
        try:
            scans, total = _chosen_scans(args, recording.scans, recording.total)
        except ValueError as err:
            print(f"navd replay: {err}", file=sys.stderr)
            return EXIT_USAGE
        _load_kernels()
        result = replay(
            scans,
            args.out,
            settings,
            mount=mount,
            odometry=args.odometry,
            progress=None if args.quiet else _progress_line(total),
            start_map=start_map,
            fine_cell_m=args.fine_resolution,
        )
    except (SlamError, OfflineError) as err:
        said = str(err)
        if args.scans is not None and isinstance(err, LogFormatError) and "no laser scans" in said:
            said = f"--scans {args.scans} picked no scans (the log has fewer)"
        where = "" if str(args.log) in said else f"{args.log}: "
        print(f"navd replay: {where}{said}", file=sys.stderr)
        return EXIT_USAGE
    except OSError as err:
        print(f"navd replay: {err}", file=sys.stderr)
        return EXIT_FAILED
    if not args.quiet:
        print(file=sys.stderr)
    print(json.dumps(result.summary, indent=2))
    return EXIT_OK


def _chosen_scans(
    args: argparse.Namespace, scans: Iterable[LogScan], total: int
) -> tuple[Iterable[LogScan], int]:
    """The scans ``--scans`` picks, made worse as ``--perturb`` says, and how many.

    Raises:
        ValueError: a bad --scans or --perturb, named.
    """
    from navd.offline import perturb  # noqa: PLC0415 - only replay needs SLAM

    if args.scans is not None:
        try:
            first, last = _scan_range(args.scans)
        except ValueError as err:
            raise ValueError(f"--scans {args.scans}: {err}") from err
        scans = itertools.islice(scans, first, last)
        total = max(0, min(total, last if last is not None else total) - first)
    if args.perturb is not None:
        try:
            scans = perturb(scans, args.perturb, args.seed)
        except ValueError as err:
            raise ValueError(f"--perturb: {err}") from err
    return scans, total


def _scan_range(text: str) -> tuple[int, int | None]:
    """FROM:TO as (first, end or None); either may be empty.

    Raises:
        ValueError: not two counts around a colon, negative, or TO before FROM.
    """
    if text.count(":") != 1:
        raise ValueError("give FROM:TO, e.g. 0:3000 or 3000:")
    head, tail = text.split(":")
    try:
        first = int(head) if head.strip() else 0
        last = int(tail) if tail.strip() else None
    except ValueError:
        raise ValueError("FROM and TO are scan counts (whole numbers)") from None
    if first < 0 or (last is not None and last <= first):
        raise ValueError("FROM must be >= 0 and TO greater than FROM")
    return first, last


def _play(args: argparse.Namespace) -> int:
    """A navd recording through the whole pipeline; the differences with what was recorded."""
    import asyncio  # noqa: PLC0415
    import tempfile  # noqa: PLC0415

    from navd.app import build_modules  # noqa: PLC0415 - only playback needs the daemon
    from navd.viz import (  # noqa: PLC0415
        RecordingError,
        play,
        read_recording,
    )

    try:
        recording = read_recording(args.log, args.session)
        with tempfile.TemporaryDirectory(prefix="navd-play-") as tmp:
            work = args.out if args.out is not None else Path(tmp)
            report = asyncio.run(play(recording, build_modules, work))
    except RecordingError as err:
        print(f"navd replay: {err}", file=sys.stderr)
        return EXIT_USAGE
    summary = report.as_dict()
    text = json.dumps(summary, indent=2)
    print(text)
    if args.out is not None:
        args.out.mkdir(parents=True, exist_ok=True)
        (args.out / "playback.json").write_text(text + "\n", encoding="utf-8")
    for line in report.differences:
        print(f"navd replay: differs: {line}", file=sys.stderr)
    if report.cut_short:
        print(
            f"navd replay: {len(report.cut_short)} file(s) ended mid-way (replayed up to their "
            f"last whole chunk): {', '.join(report.cut_short)}",
            file=sys.stderr,
        )
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


def _relations(args: argparse.Namespace) -> int:
    from navd.offline import (  # noqa: PLC0415
        OfflineError,
        evaluate,
        read_relations,
        read_tum,
    )

    try:
        stamps, poses = read_tum(args.trajectory)
        errors = evaluate(stamps, poses, read_relations(args.relations))
    except (OfflineError, OSError) as err:
        print(f"navd eval relations: {err}", file=sys.stderr)
        return EXIT_USAGE
    print_figures(errors.as_dict(), args.json)
    return EXIT_OK if errors.used else EXIT_FAILED
