"""``navd config check|dump|get|set``: validate a config file, print the effective one, or
read and change a key of the running daemon's."""

from __future__ import annotations

import argparse
import json
import sys
import tomllib
from pathlib import Path

import tomli_w
from pydantic import ValidationError

from navd.cli.common import (
    EXIT_FAILED,
    EXIT_OK,
    EXIT_USAGE,
    Commands,
    connect,
    connection_options,
    load,
)
from navd.config import ConfigError, dump_toml, load_config
from navd.drivers.client import ClientError
from navd.drivers.protocol.frames import ConfigFrame, ConfigGetFrame
from navd.drivers.protocol.replies import ConfigAppliedFrame, ConfigRejectedFrame

__all__ = ["add_commands"]


def add_commands(commands: Commands) -> None:
    """Add ``config check``, ``dump``, ``get`` and ``set``."""
    config = commands.add_parser(
        "config", help="check or dump a config file; get or set the running daemon's keys"
    )
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
    get = actions.add_parser("get", help="a key (or a section) of the running daemon's config")
    get.add_argument("key", help="dotted key, e.g. planning.goal_weight, or a section: planning")
    connection_options(get)
    get.set_defaults(handler=_get)
    put = actions.add_parser(
        "set", help="change a key of the running daemon's config (applied whole or refused)"
    )
    put.add_argument("key", help="dotted key, e.g. planning.goal_weight")
    put.add_argument("value", help='a TOML value: 2.5, true, "text" (a bare word is taken as text)')
    connection_options(put)
    put.set_defaults(handler=_set)


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


def _get(args: argparse.Namespace) -> int:
    try:
        frame = ConfigGetFrame(key=args.key)
    except ValidationError:
        print(f"navd config get: {args.key!r} is not a dotted key (section.key)", file=sys.stderr)
        return EXIT_USAGE
    try:
        with connect(args) as client:
            ack = client.request(frame)
    except (ClientError, ConfigError) as err:
        print(f"navd config get: {err}", file=sys.stderr)
        return EXIT_FAILED
    print(json.dumps(ack.value) if isinstance(ack.value, dict | list) else _toml_value(ack.value))
    return EXIT_OK


def _toml_value(value: object) -> str:
    """A value as TOML writes it (unset: nothing)."""
    if value is None:
        return ""
    return tomli_w.dumps({"v": value}).split("=", 1)[1].strip()


def _parsed(text: str) -> object:
    """A TOML value, or the text itself when it is not one (a bare word)."""
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        return text


def _set(args: argparse.Namespace) -> int:
    value = _parsed(args.value)
    try:
        with connect(args) as client:
            ack = client.request(ConfigFrame(changes={args.key: value}))
            while True:
                answer = client.receive()
                if (
                    isinstance(answer, ConfigAppliedFrame | ConfigRejectedFrame)
                    and answer.request_id == ack.request_id
                ):
                    break
    except (ClientError, ConfigError) as err:
        print(f"navd config set: {err}", file=sys.stderr)
        return EXIT_FAILED
    if isinstance(answer, ConfigRejectedFrame):
        print(f"navd config set: refused: {answer.reason}", file=sys.stderr)
        return EXIT_FAILED
    print(f"{args.key} = {_toml_value(value)}" + ("" if answer.changed else " (unchanged)"))
    return EXIT_OK
