"""``navd eval perturb``: the robustness suite over one laser log and its relations."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

from navd.cli.common import EXIT_FAILED, EXIT_OK, EXIT_USAGE, load
from navd.config import ConfigError

__all__ = ["add_suite_command"]


def add_suite_command(metrics: Any) -> None:
    """Add ``perturb`` to ``navd eval``'s metrics (``metrics``: its subparsers)."""
    suite = metrics.add_parser(
        "perturb",
        help="the robustness suite: replay a laser log as it is and made worse in each way, "
        "scored on its relations (docs/slam.md, 'Perturbed logs')",
    )
    suite.add_argument("log", type=Path, help="a laser log or bag, as for navd replay")
    suite.add_argument("relations", type=Path, help=".relations file (t1 t2 x y z r p y)")
    suite.add_argument("--out", type=Path, required=True, help="folder for each replay's results")
    suite.add_argument(
        "--kinds",
        help="comma-separated perturbations, each a kind of navd replay --perturb or kinds "
        "joined by '+' (default: every kind alone, and the combinations that stand for the "
        "held-out logs' conditions)",
    )
    suite.add_argument("--seed", type=int, default=0, help="seed of the perturbations (0)")
    suite.add_argument("--config", type=Path, help="TOML config (its slam and lidar sections)")
    suite.add_argument(
        "--max-ratio",
        type=float,
        help="exit 1 if a perturbed run's mean error is more than this many times the log's own",
    )
    suite.add_argument("--json", action="store_true", help="print JSON (default: a table)")
    suite.add_argument("--quiet", action="store_true", help="no line per replay as it ends")
    suite.set_defaults(handler=_suite)


def _suite(args: argparse.Namespace) -> int:
    from navd.geometry import LidarMount  # noqa: PLC0415 - only the suite needs SLAM
    from navd.offline import OfflineError, open_recording, read_relations, replay_mount  # noqa: PLC0415
    from navd.offline.perturb_suite import (  # noqa: PLC0415
        SUITE,
        SuiteRow,
        run_suite,
        suite_table,
        worst_row,
    )
    from navd.slam import MapperSettings, SlamError  # noqa: PLC0415

    said = "navd eval perturb"
    try:
        config = load(args.config)
        relations = read_relations(args.relations)
        first = open_recording(args.log)
    except (ConfigError, OfflineError, OSError) as err:
        print(f"{said}: {err}", file=sys.stderr)
        return EXIT_USAGE
    kinds = tuple(k.strip() for k in args.kinds.split(",")) if args.kinds else SUITE
    mount = replay_mount(LidarMount.of(config.lidar), first.mount)

    def done(row: SuiteRow) -> None:
        if not args.quiet:
            print(
                f"{row.kind}: {row.errors.translation_mean_m:.4f} m, x{row.ratio:.2f}, "
                f"{row.wall_s:.0f} s",
                file=sys.stderr,
            )

    try:
        rows = run_suite(
            lambda: open_recording(args.log).scans,
            relations,
            MapperSettings.from_config(config),
            mount,
            args.out,
            kinds=kinds,
            seed=args.seed,
            progress=done,
        )
    except ValueError as err:
        print(f"{said}: --kinds: {err}", file=sys.stderr)
        return EXIT_USAGE
    except (OfflineError, SlamError, OSError) as err:
        print(f"{said}: {args.log}: {err}", file=sys.stderr)
        return EXIT_USAGE
    worst = worst_row(rows)
    if args.json:
        print(json.dumps({"rows": [r.as_dict() for r in rows], "worst": worst.as_dict()}, indent=2))
    else:
        print(suite_table(rows))
        print(f"\nworst: {worst.kind}, x{worst.ratio:.2f} of the log's own error")
    if args.max_ratio is not None and not worst.ratio <= args.max_ratio:
        print(
            f"{said}: {worst.kind} is x{worst.ratio:.2f} of the log's own error, over "
            f"--max-ratio {args.max_ratio}",
            file=sys.stderr,
        )
        return EXIT_FAILED
    return EXIT_OK
