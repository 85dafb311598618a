"""The log taps: every line reaches them once, and nothing a tap does costs a line."""

from __future__ import annotations

import io
import json
from collections.abc import Mapping
from typing import Any

import pytest

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


def test_under_systemd_each_line_starts_with_its_syslog_priority(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """journald reads ``<N>`` at a line's start as its priority, for ``journalctl -p``."""
    out = io.StringIO()
    monkeypatch.setenv("JOURNAL_STREAM", "8:12345")
    configure_logging("debug", "json", stream=out)
    log = get_logger("test")
    try:
        log.debug("d")
        log.info("i")
        log.warning("w", detail=1)
        log.error("e")
    finally:
        monkeypatch.delenv("JOURNAL_STREAM")
        configure_logging("warning", "auto")
    lines = out.getvalue().splitlines()
    assert [line[:3] for line in lines] == ["<7>", "<6>", "<4>", "<3>"]
    assert json.loads(lines[2][3:])["detail"] == 1  # the rest is the JSON line as before
    plain = io.StringIO()
    configure_logging("info", "json", stream=plain)  # not under systemd: no prefix
    try:
        get_logger("test").warning("w")
    finally:
        configure_logging("warning", "auto")
    assert plain.getvalue().startswith("{")
