"""The open-file limit raised at start: a process started with the common soft limit of
1024 (or lower) gets what its hard limit allows, up to the wanted count."""

from __future__ import annotations

import resource
import subprocess
import sys

from navd.lifecycle.file_limit import WANTED_FILES

SCRIPT = """
from navd.lifecycle.file_limit import raise_file_limit
print(*raise_file_limit())
"""


def _lowered() -> None:
    _, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    resource.setrlimit(resource.RLIMIT_NOFILE, (256, hard))


def test_a_low_soft_limit_is_raised_within_the_hard_one() -> None:
    _, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    run = subprocess.run(
        [sys.executable, "-c", SCRIPT], preexec_fn=_lowered, capture_output=True, text=True,
        check=True, timeout=60,
    )  # fmt: skip
    before, after = (int(v) for v in run.stdout.split())
    assert before == 256
    expected = WANTED_FILES if hard == resource.RLIM_INFINITY else min(WANTED_FILES, hard)
    assert after == max(expected, 256)
