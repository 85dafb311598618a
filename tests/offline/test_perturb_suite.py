"""``navd eval perturb``: the robustness suite over a log, scored on its relations."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from navd.cli import main
from navd.geometry import Pose2
from tests.offline.test_logs_and_relations import _write_dump

# A drive round the synthetic room at 0.5 m/s, 10 scans a second.
DRIVE = [Pose2(-2.0 + 0.05 * i, -1.0 + 0.02 * i, 0.01 * i) for i in range(80)]


def _log_and_relations(folder: Path) -> tuple[Path, Path]:
    log = _write_dump(folder, DRIVE)
    lines = []
    for i in range(0, len(DRIVE) - 10, 4):  # even scans: every2 keeps them
        d = DRIVE[i].between(DRIVE[i + 10])
        lines.append(f"{100 + 0.1 * i:.6f} {100 + 0.1 * (i + 10):.6f} {d.x} {d.y} 0 0 0 {d.yaw}")
    relations = folder / "room.relations"
    relations.write_text("\n".join(lines) + "\n")
    return log, relations


def test_the_suite_scores_each_perturbation_against_the_log_as_it_is(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    log, relations = _log_and_relations(tmp_path)
    out = tmp_path / "suite"
    args = ["eval", "perturb", str(log), str(relations), "--out", str(out), "--quiet"]
    assert main([*args, "--kinds", "every2,spurious+odometry_spikes", "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    rows = {r["kind"]: r for r in report["rows"]}
    assert list(rows) == ["none", "every2", "spurious+odometry_spikes"]
    assert rows["none"]["ratio"] == 1.0
    assert rows["none"]["used"] == rows["every2"]["used"] == 18
    for row in rows.values():
        assert row["translation_mean_m"] < 0.05  # a clean room: every run tracks it
    # each replay's results are kept, and its trajectory is its own
    every2 = (out / "every2" / "trajectory.tum").read_text().splitlines()
    assert len(every2) == 40
    assert len((out / "none" / "trajectory.tum").read_text().splitlines()) == 80
    assert report["worst"]["kind"] in ("every2", "spurious+odometry_spikes")
    worst = max(rows["every2"]["ratio"], rows["spurious+odometry_spikes"]["ratio"])
    assert report["worst"]["ratio"] == worst


def test_the_suite_fails_past_its_ratio_and_refuses_an_unknown_kind(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    log, relations = _log_and_relations(tmp_path)
    args = ["eval", "perturb", str(log), str(relations), "--quiet", "--out"]
    assert main([*args, str(tmp_path / "s"), "--kinds", "noise", "--max-ratio", "0.01"]) == 1
    said = capsys.readouterr()
    assert "| noise |" in said.out  # the table is printed all the same
    assert "noise is x" in said.err and "over --max-ratio 0.01" in said.err
    assert main([*args, str(tmp_path / "t"), "--kinds", "every2,evry3"]) == 2
    assert "--kinds: unknown perturbation 'evry3'" in capsys.readouterr().err
    assert not (tmp_path / "t").exists()  # refused before any replay
