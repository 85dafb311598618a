"""Setting keys of one table in a person's config file: the rest stays, the result is a
valid config or nothing changes."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from navd.config import ConfigError, load_config
from navd.config.edit import set_table_keys
from navd.config.loader import toml_key

WRITTEN = """\
# the yard rover
[mounts.compasses.c0]
soft_iron = [
    [1.0, 0.0],  # written by hand
    [0.0, 1.0],
]
yaw_rad = 0.2  # the chip sits turned

[robot]
name = "rover"
"""


def test_a_multi_line_value_is_replaced_whole_and_the_rest_kept(tmp_path: Path) -> None:
    path = tmp_path / "navd.toml"
    path.write_text(WRITTEN)
    set_table_keys(path, "mounts.compasses.c0", {"soft_iron": [[1.1, 0.0], [0.0, 0.9]]})
    text = path.read_text()
    assert "written by hand" not in text and text.count("soft_iron") == 1
    assert "# the chip sits turned" in text and 'name = "rover"' in text
    config = load_config(path)
    assert config.mounts.compasses["c0"].soft_iron == ((1.1, 0.0), (0.0, 0.9))
    assert config.mounts.compasses["c0"].yaw_rad == 0.2


def test_a_missing_file_is_made(tmp_path: Path) -> None:
    path = tmp_path / "new.toml"
    set_table_keys(path, "mounts.compasses.c0", {"hard_iron_ut": [1.0, 2.0]})
    assert load_config(path).mounts.compasses["c0"].hard_iron_ut == (1.0, 2.0)


def test_an_unwritable_folder_is_said_and_the_file_kept(tmp_path: Path) -> None:
    if os.geteuid() == 0:
        pytest.skip("root may write any folder")
    locked = tmp_path / "locked"
    locked.mkdir()
    (locked / "navd.toml").write_text(WRITTEN)
    locked.chmod(0o500)
    try:
        with pytest.raises(PermissionError):
            set_table_keys(locked / "navd.toml", "robot", {"name": "x"})
    finally:
        locked.chmod(0o700)
    assert (locked / "navd.toml").read_text() == WRITTEN


def test_a_key_the_model_does_not_know_is_refused_by_name(tmp_path: Path) -> None:
    path = tmp_path / "navd.toml"
    path.write_text(WRITTEN)
    with pytest.raises(ConfigError, match="hard_iron"):
        set_table_keys(path, "mounts.compasses.c0", {"hard_iron": [1.0, 2.0]})
    assert path.read_text() == WRITTEN


def test_a_device_id_with_dots_is_one_quoted_table(tmp_path: Path) -> None:
    path = tmp_path / "navd.toml"
    path.write_text(WRITTEN)
    table = f"mounts.compasses.{toml_key('qmc.i2c-1:0d')}"
    set_table_keys(path, table, {"yaw_rad": 0.5})
    set_table_keys(path, table, {"yaw_rad": 0.25})  # found again, not added twice
    assert path.read_text().count("qmc.i2c-1:0d") == 1
    assert load_config(path).mounts.compasses["qmc.i2c-1:0d"].yaw_rad == 0.25
