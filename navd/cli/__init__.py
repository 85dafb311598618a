"""The ``navd`` command line: one module per group of commands, each thin.

The only place in navd that prints and chooses exit codes.
Exit codes: 0 success, 1 the daemon (or a command's work) failed at run time, 2 bad usage or
bad config, 3 a goal followed with ``navd goal --wait`` (or a mission with ``navd mission run
--wait``) was canceled.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence

from navd import __version__
from navd.cli import (
    bench,
    completion,
    config,
    control,
    fleet,
    mission,
    robot,
    run,
    sensor,
    sim,
    slam,
    teleop,
    viz,
)
from navd.cli.common import EXIT_USAGE
from navd.logs import configure_logging

__all__ = ["main"]

# The command groups, in the order `navd --help` lists them.
GROUPS = (
    run,
    config,
    control,
    mission,
    fleet,
    robot,
    teleop,
    sensor,
    bench,
    slam,
    sim,
    viz,
    completion,
)


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
    code: int = args.handler(args)
    return code


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="navd", description="navd: a navigation daemon for small ground robots."
    )
    parser.add_argument("--version", action="version", version=f"navd {__version__}")
    commands = parser.add_subparsers(dest="command", metavar="COMMAND")
    for group in GROUPS:
        group.add_commands(commands)
    return parser
