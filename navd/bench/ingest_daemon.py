"""The daemon with only its ingest path: the TCP server and the safety gate, no consumers.

``python -m navd.bench.ingest_daemon --config FILE`` runs it (the ingest benchmark starts it
beside the whole daemon, to tell the cost of taking sensor data in from the cost of what the
estimator, SLAM and the planner then do with it).
"""

from __future__ import annotations

import argparse
import asyncio
from pathlib import Path

from navd.config import load_config
from navd.drivers import TcpServer
from navd.lifecycle import Daemon, SafetyGate
from navd.logs import configure_logging


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--config", type=Path, required=True)
    args = parser.parse_args()
    config = load_config(args.config)
    configure_logging(config.logging.level, config.logging.format)
    daemon = Daemon(config, [SafetyGate(), TcpServer()], config_path=args.config)
    if config.lifecycle.event_loop == "uvloop":
        import uvloop  # noqa: PLC0415

        uvloop.run(daemon.run())
    else:
        asyncio.run(daemon.run())


if __name__ == "__main__":
    main()
