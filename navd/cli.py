"""The ``navd`` command line: run the daemon, check and dump configs.

The only place in navd that prints and chooses exit codes.
Exit codes: 0 success, 1 the daemon failed at run time, 2 bad usage or bad config.
"""

from __future__ import annotations

import argparse
import asyncio
import sys
from collections.abc import Sequence
from pathlib import Path

from navd import __version__
from navd.config import ConfigError, NavdConfig, dump_toml, load_config
from navd.errors import NavdError
from navd.logs import configure_logging, get_logger

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
    return parser


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
    from navd.lifecycle import Daemon  # noqa: PLC0415 - keep `navd config` fast to start

    daemon = Daemon(config, config_path=args.config)
    try:
        asyncio.run(daemon.run())
    except NavdError as err:
        get_logger("cli").error("daemon_failed", error=str(err))
        return EXIT_FAILED
    return EXIT_OK
