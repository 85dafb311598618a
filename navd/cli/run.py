"""``navd run``: the daemon."""

from __future__ import annotations

import argparse
import asyncio
import os
import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING

from navd.cli.common import EXIT_FAILED, EXIT_OK, EXIT_USAGE, Commands, load
from navd.config import ConfigError, RecordConfig
from navd.errors import NavdError
from navd.logs import configure_logging, get_logger

if TYPE_CHECKING:
    from navd.lifecycle import Daemon

__all__ = ["add_commands"]


def add_commands(commands: Commands) -> None:
    """Add ``run`` and ``kernels``."""
    run = commands.add_parser("run", help="run the daemon")
    run.add_argument("--config", type=Path, help="TOML config file (default: built-in defaults)")
    run.add_argument(
        "--record",
        type=Path,
        metavar="DIR",
        help="record the session to MCAP files in DIR (record.enabled and record.dir)",
    )
    run.set_defaults(handler=_run)
    kernels = commands.add_parser(
        "kernels",
        help="compile the daemon's numba kernels into numba's cache (once per install)",
        description=(
            "Compile every numba kernel the daemon runs into numba's cache (or load it, if it "
            "is there already), so the daemon's first start loads them instead of compiling. "
            "deploy/install.sh runs it as the service's user; a daemon that finds the cache "
            "cold runs it by itself."
        ),
    )
    kernels.add_argument(
        "--check",
        action="store_true",
        help="compile nothing: list the kernels not in the cache, exit 1 if there are any",
    )
    kernels.set_defaults(handler=_kernels)


def _run(args: argparse.Namespace) -> int:
    try:
        config = load(args.config)
        if args.record is not None:
            record = {**config.record.model_dump(), "enabled": True, "dir": str(args.record)}
            config = config.model_copy(update={"record": RecordConfig.model_validate(record)})
    except ConfigError as err:
        print(err, file=sys.stderr)
        return EXIT_USAGE
    configure_logging(config.logging.level, config.logging.format)
    from navd.app import build_modules  # noqa: PLC0415 - keep `navd config` fast to start
    from navd.kernels import KernelCache  # noqa: PLC0415
    from navd.lifecycle import Daemon  # noqa: PLC0415
    from navd.slam import MapFileError  # noqa: PLC0415

    kernels = KernelCache()
    daemon = Daemon(
        config, build_modules(config), config_path=args.config, prepare_kernels=kernels.prepare
    )
    try:
        try:
            if config.lifecycle.event_loop == "uvloop":
                import uvloop  # noqa: PLC0415

                uvloop.run(daemon.run())
            else:
                asyncio.run(daemon.run())
        finally:
            kernels.stop()  # a compile still running in its child ends with the daemon
    except MapFileError as err:  # the map the config names cannot be used: fix the input
        get_logger("cli").error("daemon_failed", error=str(err))
        return _exit_past_threads(daemon, EXIT_USAGE)
    except NavdError as err:
        get_logger("cli").error("daemon_failed", error=str(err))
        return _exit_past_threads(daemon, EXIT_FAILED)
    return _exit_past_threads(daemon, EXIT_OK)


def _kernels(args: argparse.Namespace) -> int:
    from navd.kernels import KernelCacheError, cold_kernels, warm_up_all  # noqa: PLC0415

    if args.check:
        try:
            cold = cold_kernels()
        except KernelCacheError as err:
            print(err, file=sys.stderr)
            return EXIT_FAILED
        for name in cold:
            print(f"not in the cache: {name}")
        print(f"{len(cold)} kernel(s) to compile" if cold else "every kernel is in the cache")
        return EXIT_FAILED if cold else EXIT_OK
    started = time.monotonic()
    warm_up_all()
    try:
        cold = cold_kernels()
    except KernelCacheError as err:
        print(f"compiled, but not checked: {err}", file=sys.stderr)
        return EXIT_OK
    if cold:  # numba could not write its cache (a read-only install without NUMBA_CACHE_DIR)
        print(
            f"compiled, but {len(cold)} kernel(s) are still not in numba's cache (first: "
            f"{cold[0]}): is its folder writable? Set NUMBA_CACHE_DIR to one that is.",
            file=sys.stderr,
        )
        return EXIT_FAILED
    print(f"every kernel is in numba's cache ({time.monotonic() - started:.1f} s)")
    return EXIT_OK


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
