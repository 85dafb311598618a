"""SIGTERM (a timeout, systemd, kill) ends a command as Ctrl-C does, in a real process: the
command's own clean-up runs (its children stopped, its folders removed), one line says how
it ended, and the exit code is 143 (Ctrl-C: 130). Without this, SIGTERM ended the process on
the spot and left the daemons a command had started running."""

from __future__ import annotations

import signal
import subprocess
import sys
from pathlib import Path

import pytest

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


# Ctrl-C at its default, as a shell starts a command: a test process can hold SIGINT
# ignored (asyncio leaves it as it found it), an ignored signal is inherited, and Python
# then installs no Ctrl-C handler at all.
AS_FROM_A_TERMINAL = "import signal; signal.signal(signal.SIGINT, signal.default_int_handler)\n"


def _start(script: str) -> subprocess.Popen[str]:
    process = subprocess.Popen(
        [sys.executable, "-c", AS_FROM_A_TERMINAL + script],
        cwd=REPO,
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    assert process.stdout is not None
    assert process.stdout.readline().strip() == "ready"
    return process


@pytest.mark.parametrize(
    ("script", "sig", "code", "said"),
    [
        (BLOCKING_COMMAND, signal.SIGTERM, 143, "SIGTERM"),  # blocked in a read of a pipe
        (ASYNC_COMMAND, signal.SIGTERM, 143, "SIGTERM"),  # asyncio's task cancelled first
        (BLOCKING_COMMAND, signal.SIGINT, 130, "Ctrl-C"),  # one line, no traceback
    ],
    ids=["sigterm-in-a-read", "sigterm-in-asyncio", "ctrl-c"],
)
def test_a_signal_ends_a_command_through_its_clean_up_with_one_line(
    script: str, sig: signal.Signals, code: int, said: str
) -> None:
    process = _start(script)
    process.send_signal(sig)
    # its standard input stays open until it has ended: closing it too (as communicate
    # does) could end the read before the signal does on a busy machine
    process.wait(timeout=10)
    assert process.stdout is not None and process.stderr is not None
    out, err = process.stdout.read(), process.stderr.read()
    for pipe in (process.stdin, process.stdout, process.stderr):
        if pipe is not None:
            pipe.close()
    assert process.returncode == code
    assert out.strip() == "cleaned up"
    assert err.strip() == f"navd barn: ended by {said}"
