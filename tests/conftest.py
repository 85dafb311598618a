"""Shared test helpers: a bus on simulated time and message and frame factories; property
tests draw the same examples on every run (derandomized, no example database), so a run
fails or passes on the code alone."""

from __future__ import annotations

import math
import subprocess
import sys
from collections.abc import Callable
from typing import Any

import pytest
from hypothesis import settings

from navd.lifecycle import Bus, SimClock, Supervisor
from navd.lifecycle.messages import Message, VelocityCommand
from navd.wire import ScanFrame

settings.register_profile("navd", derandomize=True, database=None)
settings.load_profile("navd")


def fresh_process_output(script: str, timeout_s: float = 300.0) -> str:
    """What ``script`` prints when run by a new Python interpreter (so nothing this test
    process imported or compiled counts); fails the test, with its stderr, if it fails."""
    done = subprocess.run(
        [sys.executable, "-c", script],
        capture_output=True,
        text=True,
        timeout=timeout_s,
        check=False,
    )
    assert done.returncode == 0, done.stderr[-3000:]
    return done.stdout.strip()


def velocity(linear: float = 0.1, angular: float = 0.0, t: float = 0.0) -> VelocityCommand:
    """A VelocityCommand stamped at ``t``."""
    return VelocityCommand(
        stamp=t, received=t, linear_mps=linear, angular_radps=angular, source="test"
    )


def room_scan(stamp: float) -> ScanFrame:
    """What a 360-ray lidar in the middle of an 8 m square room sees, stamped ``stamp``."""
    angles = [-math.pi + 2 * math.pi * k / 360 for k in range(360)]
    ranges = [4.0 / max(abs(math.cos(a)), abs(math.sin(a))) for a in angles]
    return ScanFrame(
        stamp=stamp,
        angle_min=-math.pi,
        angle_increment=2 * math.pi / 360,
        range_min=0.05,
        range_max=12.0,
        ranges=ranges,
    )


@pytest.fixture
def clock() -> SimClock:
    return SimClock(start_s=100.0)


@pytest.fixture
def bus(clock: SimClock) -> Bus:
    return Bus(
        clock, Supervisor(max_failures=3, window_s=10.0), handler_budget_s=10.0, max_cascade=100
    )


@pytest.fixture
def recorder() -> Callable[[list[Any]], Callable[[Message], None]]:
    def make(into: list[Any]) -> Callable[[Message], None]:
        return into.append

    return make


@pytest.fixture(autouse=True)
def _quiet_logs() -> None:
    """In-process daemons log only warnings and errors during tests."""
    import sys

    from navd.logs import configure_logging

    configure_logging("warning", "console", stream=sys.stderr)
