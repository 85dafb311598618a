"""The mounts section: device ids as table names, one kind per id, strict values."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from pydantic import ValidationError

from navd.config import ConfigError, NavdConfig, load_config


@pytest.mark.parametrize(
    ("mounts", "named"),
    [
        ({"lidars": {"bad id!": {}}}, "mounts.lidars.bad id!"),
        ({"lidars": {"a": {}}, "gps": {"a": {}}}, "also under mounts.lidars"),
        ({"lidars": {"a": {"x_m": "0.2"}}}, "x_m"),
        ({"lidars": {"a": {"height_m": 0.2}}}, "height_m"),
        ({"gps": {"g": {"x_m": 9.0}}}, "x_m"),
    ],
)
def test_a_bad_mount_is_refused_by_name(mounts: dict[str, object], named: str) -> None:
    with pytest.raises(ValidationError, match=re.escape(named)):
        NavdConfig.model_validate({"mounts": mounts})


def test_a_mistake_inside_a_mount_is_named_with_its_fix(tmp_path: Path) -> None:
    path = tmp_path / "navd.toml"
    path.write_text('[mounts.lidars.front]\nyaw = 1.0\n[mounts.gps.gnss0]\nx_m = "0.3"\n')
    with pytest.raises(ConfigError) as caught:
        load_config(path)
    said = str(caught.value)
    assert "mounts.lidars.front.yaw: unknown key (did you mean 'yaw_rad'?)" in said
    assert "mounts.gps.gnss0.x_m = '0.3'" in said and "[m] antenna x in base_link" in said
