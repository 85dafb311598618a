"""The log taps: every line reaches them once, and nothing a tap does costs a line."""

from __future__ import annotations

import io
from collections.abc import Mapping
from typing import Any

from navd.logs import add_log_tap, configure_logging, get_logger, remove_log_tap, tap_failures


def test_a_tap_that_logs_or_raises_costs_no_line_and_never_loops() -> None:
    out = io.StringIO()
    configure_logging("info", "json", stream=out)
    log = get_logger("test")
    seen: list[str] = []

    def echoing(event: Mapping[str, Any]) -> None:
        seen.append(str(event["event"]))
        log.info("echo", of=event["event"])  # would loop for ever if taps saw their own lines

    def broken(_event: Mapping[str, Any]) -> None:
        raise RuntimeError("tap failed")

    failures = tap_failures()
    add_log_tap(echoing)
    add_log_tap(broken)
    try:
        log.warning("first")
    finally:
        remove_log_tap(echoing)
        remove_log_tap(broken)
    log.warning("after")  # removed: not seen
    lines = out.getvalue().splitlines()
    assert seen == ["first"]
    assert [line for line in lines if '"first"' in line or '"echo"' in line] == lines[:2]
    assert len(lines) == 3  # first, the tap's echo, after: each written once
    assert tap_failures() == failures + 1
