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
from navd.config import ConfigError, NavdConfig, dump_toml, load_config
from navd.wire import (
    ClientError,
    ConfigAppliedFrame,
    ConfigFrame,
    ConfigGetFrame,
    ConfigRejectedFrame,
)

__all__ = ["add_commands"]


def add_commands(commands: Commands) -> None:
    """Add ``config check``, ``dump``, ``get`` and ``set``."""
    config = commands.add_parser(
        "config", help="check or dump a config file; get or set the running daemon's keys"
    )
    actions = config.add_subparsers(dest="config_command", metavar="ACTION", required=True)
    check = actions.add_parser(
        "check",
        help="validate a config file: its keys and values, and the files it names (the map to "
        "start on, zone masks, TLS files) read as navd would",
    )
    check.add_argument("file", type=Path, help="TOML config file")
    check.add_argument(
        "--from",
        dest="run_dir",
        type=Path,
        default=None,
        metavar="DIR",
        help="the folder navd runs in, where it reads relative paths from (default: this one; "
        "systemd's unit runs navd in /var/lib/navd)",
    )
    check.add_argument(
        "--keys-only",
        action="store_true",
        help="check the keys and values, not the files (a config for another machine)",
    )
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
        config = load_config(args.file)
    except ConfigError as err:
        print(err, file=sys.stderr)
        return EXIT_USAGE
    if args.keys_only and args.run_dir is not None:
        print("navd config check: --from reads files; --keys-only reads none", file=sys.stderr)
        return EXIT_USAGE
    problems = [] if args.keys_only else _file_problems(config, args.run_dir or Path.cwd())
    if problems:
        print(ConfigError(problems, source=str(args.file)), file=sys.stderr)
        return EXIT_USAGE
    print(f"{args.file}: ok")
    return EXIT_OK


def _file_problems(config: NavdConfig, here: Path) -> list[str]:
    """What is wrong with the files the config names, read as the daemon would read them from
    ``here``: the map to start on and the zone masks are loaded, the broker's TLS files
    opened (with the fleet on). One line per key, naming it (relative paths say which
    folder they were read from: navd reads them from the folder it runs in)."""
    from navd.planning import ZoneError, load_zone_mask  # noqa: PLC0415 - check only
    from navd.slam import (  # noqa: PLC0415
        MapFileError,
        load_map_state,
    )

    def relative(name: str) -> str:
        if Path(name).is_absolute():
            return ""
        return f" (a relative path: read from {here}; navd reads it from where it runs: --from DIR)"

    problems = []
    if config.slam.load_map is not None:
        try:
            load_map_state(here / config.slam.load_map)
        except MapFileError as err:
            problems.append(f"slam.load_map: {err}{relative(config.slam.load_map)}")
    for key, name in (
        ("planning.keep_out_mask", config.planning.keep_out_mask),
        ("planning.speed_mask", config.planning.speed_mask),
    ):
        if name is not None:
            try:
                load_zone_mask(here / name)
            except ZoneError as err:
                problems.append(f"{key}: {err}{relative(name)}")
    tls = (
        ("fleet.ca_file", config.fleet.ca_file),
        ("fleet.cert_file", config.fleet.cert_file),
        ("fleet.key_file", config.fleet.key_file),
    )
    for key, name in tls if config.fleet.enabled else ():  # a fleet off opens none of them
        if name is not None:
            try:
                (here / name).open("rb").close()
            except OSError as err:
                problems.append(
                    f"{key}: {here / name}: cannot be read: {err.strerror}{relative(name)}"
                )
    return problems


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
