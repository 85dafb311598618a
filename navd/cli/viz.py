"""``navd viz layout``: the layout of the live view, for Foxglove's "Import layout" or
Lichtblick's "Import from file" (``--for lichtblick``)."""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
from pathlib import Path

from navd.cli.common import EXIT_OK, EXIT_USAGE, Commands

__all__ = ["add_commands"]


def add_commands(commands: Commands) -> None:
    """Add ``viz layout``."""
    viz = commands.add_parser("viz", help="the live view (Foxglove, Lichtblick)")
    actions = viz.add_subparsers(dest="viz_command", metavar="ACTION", required=True)
    layout = actions.add_parser(
        "layout", help="print the layout of the live view (or write it to --out)"
    )
    layout.add_argument("--out", type=Path, help="write the layout to this JSON file")
    layout.add_argument(
        "--for",
        dest="viewer",
        choices=("foxglove", "lichtblick"),
        default="foxglove",
        help="the viewer that imports it: Foxglove (the SDK's format, the default) or "
        "Lichtblick (the panels-by-id format; the pose from /pose/in_frame)",
    )
    layout.set_defaults(handler=_layout)


def _layout(args: argparse.Namespace) -> int:
    from navd.viz import lichtblick_layout, live_layout  # noqa: PLC0415 - the SDK loads only when asked

    if args.viewer == "lichtblick":
        text = json.dumps(lichtblick_layout(), indent=2) + "\n"
    else:
        text = live_layout().to_json() + "\n"
    if args.out is None:
        sys.stdout.write(text)
        return EXIT_OK
    out: Path = args.out
    if not out.parent.is_dir():
        print(f"cannot write {out}: folder {out.parent} does not exist", file=sys.stderr)
        return EXIT_USAGE
    # Written whole or not at all: a half-written layout would not import.
    with tempfile.NamedTemporaryFile("w", dir=out.parent, delete=False, suffix=".tmp") as tmp:
        try:
            tmp.write(text)
        except OSError:
            os.unlink(tmp.name)
            raise
    os.chmod(tmp.name, 0o644)  # a layout is for anyone to read, like the file it replaces
    os.replace(tmp.name, out)
    print(f"wrote {out}")
    return EXIT_OK
