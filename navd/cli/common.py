"""What the command groups share: exit codes, the config, a connection, printing figures."""

from __future__ import annotations

import argparse
import json
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from navd.config import NavdConfig, load_config

__all__ = [
    "EXIT_CANCELED",
    "EXIT_FAILED",
    "EXIT_INTERRUPTED",
    "EXIT_OK",
    "EXIT_TERMINATED",
    "EXIT_USAGE",
    "Commands",
    "connect",
    "connection_options",
    "load",
    "print_figures",
]

EXIT_OK = 0
EXIT_FAILED = 1
EXIT_USAGE = 2
EXIT_CANCELED = 3  # ``navd goal --wait``: the goal was canceled
EXIT_INTERRUPTED = 130  # ended by Ctrl-C (128 + SIGINT, as shells report it)
EXIT_TERMINATED = 143  # ended by SIGTERM (128 + SIGTERM)

Commands = Any  # argparse's sub-parsers action (its class is private)


def load(path: Path | None) -> NavdConfig:
    """The config in ``path``, or the built-in defaults.

    Raises:
        ConfigError: naming every bad key.
    """
    return NavdConfig() if path is None else load_config(path)


def connection_options(parser: argparse.ArgumentParser) -> None:
    """The options that say where navd listens."""
    parser.add_argument("--config", type=Path, help="take host, port and token from this file")
    parser.add_argument("--host", help="navd address (default: tcp.host, 127.0.0.1)")
    parser.add_argument("--port", type=int, help="navd port (default: tcp.port, 7420)")
    parser.add_argument("--token", help="shared secret (default: tcp.token or $NAVD_TOKEN)")


def connect(args: argparse.Namespace) -> Any:
    """A control connection to navd as ``connection_options`` say.

    Raises:
        ConfigError: the config file is bad.
        ClientError: navd cannot be reached or refused the client.
    """
    from navd.wire import Client  # noqa: PLC0415 - only the client commands need it

    tcp = load(args.config).tcp
    host = args.host or ("127.0.0.1" if tcp.host in ("0.0.0.0", "::") else tcp.host)
    token = args.token or tcp.token or os.environ.get("NAVD_TOKEN")
    return Client(host, args.port or tcp.port, device_id=f"cli-{os.getpid()}", token=token)


def print_figures(figures: Mapping[str, object], as_json: bool) -> None:
    """A benchmark's or an evaluation's figures, as JSON or one per line."""
    if as_json:
        print(json.dumps(figures, indent=2))
    else:
        for key, value in figures.items():
            print(f"{key:>34}: {value}")
