"""The wheels stop when the daemon cannot stop them: the real daemon, driven by hand on a
chassis pseudo-terminal, is frozen (SIGSTOP: its loop writes nothing, as in a stall that
holds the GIL) and then killed (SIGKILL); each time the stall watch writes "0 0"."""

from __future__ import annotations

import signal
import time
from pathlib import Path
from typing import Any

from tests.e2e.conftest import STOP_S
from tests.e2e.driving import driven_daemon, moving

REACTION_S = 0.5  # safety.reaction_timeout_s, the default
# [s] the watch looks every period (50 ms); beyond that, a busy machine's scheduling
ALLOWANCE_S = 0.35


def test_a_frozen_or_killed_daemon_has_its_wheels_stopped_by_the_watch(
    spawn_daemon: Any, tmp_path: Path
) -> None:
    with driven_daemon(spawn_daemon, tmp_path, "[viz]\nenabled = false\n") as driving:
        daemon, _, wheels = driving
        # frozen: the daemon writes nothing more; its last line was a moving one
        daemon.proc.send_signal(signal.SIGSTOP)
        frozen = time.monotonic()
        last = max(at for at, text in wheels.since(frozen - 1.0))
        stopped = wheels.wait_for(lambda t: t == "0 0", frozen, 5.0)
        assert stopped - last <= REACTION_S + ALLOWANCE_S
        time.sleep(0.5)  # it stays stopped while the daemon stays frozen, said every period
        assert all(text == "0 0" for _, text in wheels.since(stopped))
        assert len(wheels.since(stopped)) >= 3
        daemon.proc.send_signal(signal.SIGCONT)
        said = daemon.wait_for("chassis_stall_stopped", timeout_s=10.0)
        assert said["stop_lines"] >= 4
        wheels.wait_for(moving, time.monotonic(), 10.0)  # driven again once it runs
        # killed while driving: the watch sees its daemon go and stops the wheels at once
        daemon.proc.send_signal(signal.SIGKILL)
        killed = time.monotonic()
        stopped = wheels.wait_for(lambda t: t == "0 0", killed, 5.0)
        assert stopped - killed <= ALLOWANCE_S
        time.sleep(0.3)
        assert [text for _, text in wheels.since(stopped)] == []  # the watch is gone too


def test_a_daemon_stopped_after_a_stall_exits_0_without_a_traceback(
    spawn_daemon: Any, tmp_path: Path
) -> None:
    # the earlier probe saw uvloop print "KeyError: 23" at SIGTERM after a stall
    with driven_daemon(spawn_daemon, tmp_path, "[viz]\nenabled = false\n") as driving:
        daemon, _, wheels = driving
        daemon.proc.send_signal(signal.SIGSTOP)
        time.sleep(1.5)  # stalled, its sensors and driver piling up lines meanwhile
        daemon.proc.send_signal(signal.SIGCONT)
        daemon.wait_for("chassis_stall_stopped", timeout_s=10.0)
        daemon.proc.send_signal(signal.SIGTERM)
        assert daemon.proc.wait(timeout=STOP_S) == 0
        daemon.wait_for("stopped", timeout_s=5.0)
        daemon._reader.join(5.0)  # every line it wrote, to its end
        said = daemon.seen + daemon.drain()
        assert not [x for x in said if x.get("event") == "non-json"], said[-5:]
        assert wheels.wait_for(lambda t: t == "0 0", time.monotonic() - 1.0, 5.0)
