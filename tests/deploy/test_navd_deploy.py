"""deploy/navd-deploy.sh with ssh and scp replaced by recorders (no robot needed)."""

from __future__ import annotations

import os
import subprocess
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
SCRIPT = REPO / "deploy" / "navd-deploy.sh"


@pytest.fixture
def fake_ssh(tmp_path: Path) -> dict[str, str]:
    log = tmp_path / "calls.log"
    remote = tmp_path / "robot-etc-navd.toml"
    remote.write_text("[safety]\nreaction_timeout_s = 0.4\n")
    ssh = tmp_path / "ssh"
    ssh.write_text(f'#!/bin/sh\necho "ssh $*" >> {log}\n')
    scp = tmp_path / "scp"
    # a pull copies the robot's file; a push records the call
    scp.write_text(
        f'#!/bin/sh\necho "scp $*" >> {log}\n'
        f'case "$1" in *:/etc/navd/navd.toml) cp {remote} "$2";; esac\n'
    )
    for tool in (ssh, scp):
        tool.chmod(0o755)
    return {**os.environ, "NAVD_SSH": str(ssh), "NAVD_SCP": str(scp), "LOG": str(log)}


def run(env: dict[str, str], *args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        ["bash", str(SCRIPT), *args],
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
    )


def calls(env: dict[str, str]) -> list[str]:
    path = Path(env["LOG"])
    return path.read_text().splitlines() if path.exists() else []


def test_pull_config(fake_ssh: dict[str, str], tmp_path: Path) -> None:
    dest = tmp_path / "robots" / "bot.toml"
    result = run(fake_ssh, "pull-config", "pi@bot", str(dest))
    assert result.returncode == 0, result.stderr
    assert dest.read_text() == "[safety]\nreaction_timeout_s = 0.4\n"
    assert calls(fake_ssh) == [f"scp pi@bot:/etc/navd/navd.toml {dest}.part"]


def test_push_config_checks_the_file_first(fake_ssh: dict[str, str], tmp_path: Path) -> None:
    bad = tmp_path / "bad.toml"
    bad.write_text("[safety]\nreaction_timout_s = 0.4\n")
    result = run(fake_ssh, "push-config", "pi@bot", str(bad))
    assert result.returncode == 1
    assert "safety.reaction_timout_s: unknown key" in result.stderr
    assert calls(fake_ssh) == []  # nothing reached the robot
    good = tmp_path / "good.toml"
    good.write_text("[safety]\nreaction_timeout_s = 0.4\n")
    assert run(fake_ssh, "push-config", "pi@bot", str(good)).returncode == 0
    scp_call, ssh_call = calls(fake_ssh)
    assert scp_call == f"scp {good} pi@bot:/tmp/navd-deploy.navd.toml"
    assert "install -o root -g navd -m 0640" in ssh_call and "systemctl reload navd" in ssh_call


def test_push_builds_copies_and_installs(fake_ssh: dict[str, str]) -> None:
    result = run(fake_ssh, "push", "pi@bot")
    assert result.returncode == 0, result.stderr
    made = calls(fake_ssh)
    assert made[0] == "ssh pi@bot rm -rf /tmp/navd-deploy && mkdir -p /tmp/navd-deploy/config"
    assert made[1].startswith("scp -r ") and "navd-0.1.0-py3-none-any.whl" in made[1]
    assert made[-1] == (
        "ssh pi@bot sudo /tmp/navd-deploy/deploy/install.sh --source "
        "/tmp/navd-deploy/navd-0.1.0-py3-none-any.whl"
    )


def test_run_quotes_arguments(fake_ssh: dict[str, str]) -> None:
    assert run(fake_ssh, "run", "pi@bot", "--", "config", "dump", "--comments").returncode == 0
    assert calls(fake_ssh) == [
        "ssh pi@bot sudo -u navd /opt/navd/venv/bin/navd config dump --comments "
    ]


def test_usage_on_unknown_command(fake_ssh: dict[str, str]) -> None:
    result = run(fake_ssh, "teleport", "pi@bot")
    assert result.returncode == 2 and "push HOST" in result.stdout
