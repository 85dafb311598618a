"""``navd config check|dump``: validate a config file, or print the effective one."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from navd.cli.common import EXIT_OK, EXIT_USAGE, Commands, load
from navd.config import ConfigError, dump_toml, load_config

__all__ = ["add_commands"]


def add_commands(commands: Commands) -> None:
    """Add ``config check`` and ``config dump``."""
    config = commands.add_parser("config", help="check or dump a config file")
    actions = config.add_subparsers(dest="config_command", metavar="ACTION", required=True)
    check = actions.add_parser("check", help="validate a config file")
    check.add_argument("file", type=Path, help="TOML config file")
    check.set_defaults(handler=_check)
    dump = actions.add_parser("dump", help="print the effective config as TOML, defaults filled in")
    dump.add_argument("--config", type=Path, help="TOML config file (default: built-in defaults)")
    dump.add_argument(
        "--comments", action="store_true", help="describe every key (as in config/navd.toml)"
    )
    dump.set_defaults(handler=_dump)


def _check(args: argparse.Namespace) -> int:
    try:
        load_config(args.file)
    except ConfigError as err:
        print(err, file=sys.stderr)
        return EXIT_USAGE
    print(f"{args.file}: ok")
    return EXIT_OK


def _dump(args: argparse.Namespace) -> int:
    try:
        config = load(args.config)
    except ConfigError as err:
        print(err, file=sys.stderr)
        return EXIT_USAGE
    sys.stdout.write(dump_toml(config, comments=args.comments))
    return EXIT_OK
