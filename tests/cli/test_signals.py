"""SIGTERM (a timeout, systemd, kill) ends a command as Ctrl-C does, in a real process: the
command's own clean-up runs (its children stopped, its folders removed), one line says how
it ended, and the exit code is 143 (Ctrl-C: 130). Without this, SIGTERM ended the process on
the spot and left the daemons a command had started running."""

from __future__ import annotations

import signal
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]

# A command whose handler blocks in a read of a pipe (as `navd bench ingest` waits on its
# clients) and cleans up in a `finally`.
BLOCKING_COMMAND = """
import sys
import navd.cli.sim as sim_cli
from navd.cli import main

def blocking(_args):
    try:
        print("ready", flush=True)
        sys.stdin.readline()
        return 0
    finally:
        print("cleaned up", flush=True)

sim_cli._barn = blocking
sys.exit(main(["barn"]))
"""

# The same inside asyncio's runner, as `navd demo --fleet` and `navd sim` run their work.
ASYNC_COMMAND = """
import asyncio, sys
import navd.cli.sim as sim_cli
from navd.cli import main

async def work():
    try:
        print("ready", flush=True)
        await asyncio.sleep(60)
    finally:
        await asyncio.sleep(0.1)  # a clean-up that itself waits (a child process stopping)
        print("cleaned up", flush=True)

sim_cli._barn = lambda _args: asyncio.run(work())
sys.exit(main(["barn"]))
"""


def _start(script: str) -> subprocess.Popen[str]:
    process = subprocess.Popen(
        [sys.executable, "-c", script],
        cwd=REPO,
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    assert process.stdout is not None
    assert process.stdout.readline().strip() == "ready"
    return process


def test_sigterm_ends_a_command_blocked_in_a_read_through_its_clean_up() -> None:
    process = _start(BLOCKING_COMMAND)
    process.send_signal(signal.SIGTERM)
    out, err = process.communicate(timeout=10)
    assert process.returncode == 143
    assert out.strip() == "cleaned up"
    assert err.strip() == "navd barn: ended by SIGTERM"


def test_sigterm_cancels_asyncio_work_which_cleans_up_before_the_exit() -> None:
    process = _start(ASYNC_COMMAND)
    process.send_signal(signal.SIGTERM)
    out, err = process.communicate(timeout=10)
    assert process.returncode == 143
    assert out.strip() == "cleaned up"
    assert err.strip() == "navd barn: ended by SIGTERM"


def test_ctrl_c_says_so_in_one_line_without_a_traceback() -> None:
    process = _start(BLOCKING_COMMAND)
    process.send_signal(signal.SIGINT)
    out, err = process.communicate(timeout=10)
    assert process.returncode == 130
    assert out.strip() == "cleaned up"
    assert err.strip() == "navd barn: ended by Ctrl-C"
