"""The ``navd`` command line: one module per group of commands, each thin.

The only place in navd that prints and chooses exit codes.
Exit codes: 0 success, 1 the daemon (or a command's work) failed at run time, 2 bad usage or
bad config, 3 a goal followed with ``navd goal --wait`` (or a mission with ``navd mission run
--wait``) was canceled, 130 and 143 a command ended by Ctrl-C or SIGTERM.
"""

from __future__ import annotations

import argparse
import contextlib
import signal
import sys
import threading
from collections.abc import Iterator, Sequence
from types import FrameType

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
from navd.cli.common import EXIT_INTERRUPTED, EXIT_TERMINATED, EXIT_USAGE
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
    # `navd run` answers SIGTERM itself (a clean stop, exit 0, as systemd expects).
    with _sigterm_as_ctrl_c(enabled=args.command != "run") as terminated:
        try:
            code: int = args.handler(args)
        except KeyboardInterrupt:
            how = "SIGTERM" if terminated else "Ctrl-C"
            print(f"navd {args.command}: ended by {how}", file=sys.stderr)
            return EXIT_TERMINATED if terminated else EXIT_INTERRUPTED
    return code


@contextlib.contextmanager
def _sigterm_as_ctrl_c(*, enabled: bool) -> Iterator[list[int]]:
    """While inside, SIGTERM (a timeout, systemd, kill) ends a command as Ctrl-C does: its
    work is cancelled and cleaned up (the daemons and brokers it started stopped, its
    temporary folders removed), where the default would end the process on the spot and
    leave its children running. Yields the SIGTERMs received."""
    received: list[int] = []
    if not enabled or threading.current_thread() is not threading.main_thread():
        yield received  # (signal handlers belong to the main thread)
        return

    def on_term(signum: int, frame: FrameType | None) -> None:
        received.append(signum)
        # Whatever Ctrl-C does now: asyncio's runner cancels its main task (which cleans up
        # as it ends), elsewhere KeyboardInterrupt is raised (even in a blocking read).
        on_ctrl_c = signal.getsignal(signal.SIGINT)
        if not callable(on_ctrl_c):
            raise KeyboardInterrupt
        on_ctrl_c(signal.SIGINT, frame)

    previous = signal.signal(signal.SIGTERM, on_term)
    try:
        yield received
    finally:
        signal.signal(signal.SIGTERM, previous)


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="navd", description="navd: a navigation daemon for small ground robots."
    )
    parser.add_argument("--version", action="version", version=f"navd {__version__}")
    commands = parser.add_subparsers(dest="command", metavar="COMMAND")
    for group in GROUPS:
        group.add_commands(commands)
    return parser
