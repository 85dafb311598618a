"""Mission files as ``navd mission run`` reads them: what cannot be a mission is refused
in one line naming why, never a traceback."""

from __future__ import annotations

from pathlib import Path

import pytest

from navd.cli.mission import load_mission
from navd.config import ConfigError


def test_a_json_mission_nested_100000_deep_is_refused_by_name(tmp_path: Path) -> None:
    path = tmp_path / "deep.json"
    path.write_text('{"steps": ' + "[" * 100_000 + "]" * 100_000 + "}", encoding="utf-8")
    with pytest.raises(ConfigError, match="nested too deep"):
        load_mission(path)


def test_a_mission_file_with_steps_is_read(tmp_path: Path) -> None:
    path = tmp_path / "visit.toml"
    path.write_text('[[steps]]\nkind = "goto"\nx = 1.0\ny = 2.0\n', encoding="utf-8")
    mission = load_mission(path, "visit")
    assert mission.mission_id == "visit" and len(mission.steps) == 1
