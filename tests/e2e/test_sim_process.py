"""``navd sim`` as a program of its own, in a real process."""

from __future__ import annotations

from pathlib import Path

import tomli_w

from navd.sim import free_port
from tests.e2e.conftest import run_navd


def test_sim_with_no_navd_to_reach_says_so_and_fails(tmp_path: Path) -> None:
    # It used to play an empty world for nobody and report success (exit 0).
    port = free_port()
    config = tmp_path / "navd.toml"
    config.write_text(
        tomli_w.dumps(
            {"tcp": {"port": port}, "chassis": {"enabled": True, "port": str(tmp_path / "tty")}}
        )
    )
    result = run_navd("sim", "--config", str(config), "--limit", "7", timeout_s=60.0)
    assert result.returncode == 1, result.stderr
    lines = result.stderr.splitlines()
    # While it waits (after 5 s), what is wrong and what to start; at the end, the verdict.
    assert any(
        f"cannot reach navd at 127.0.0.1:{port}" in line and f"navd run --config {config}" in line
        for line in lines
    ), result.stderr
    assert lines[-1] == (
        f"navd sim: navd at 127.0.0.1:{port} never answered: nothing was simulated for it"
    )
