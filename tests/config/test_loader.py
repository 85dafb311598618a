from __future__ import annotations

import tomllib
from pathlib import Path

import pytest

from navd.config import ConfigError, NavdConfig, apply_changes, dump_toml, load_config

REPO = Path(__file__).resolve().parents[2]
DEFAULT_FILE = REPO / "config" / "navd.toml"


def test_default_file_is_the_commented_dump_of_the_model() -> None:
    """config/navd.toml lists every key with its default; regenerate it if this fails."""
    assert DEFAULT_FILE.read_text() == dump_toml(NavdConfig(), comments=True), (
        "config/navd.toml is out of date: run `navd config dump --comments > config/navd.toml`"
    )


def test_default_file_loads_to_the_defaults() -> None:
    assert load_config(DEFAULT_FILE) == NavdConfig()


def test_default_file_names_every_key() -> None:
    document = tomllib.loads(DEFAULT_FILE.read_text())
    text = DEFAULT_FILE.read_text()
    for section, field in NavdConfig.model_fields.items():
        assert field.annotation is not None
        for key in field.annotation.model_fields:  # type: ignore[union-attr]
            shown = key in document[section] or f"# {key} = " in text
            # a table of named tables shows an example table: ``# [mounts.lidars.front]``
            shown = shown or f"# [{section}.{key}." in text
            assert shown, f"{section}.{key} missing"


def test_mount_examples_in_the_default_file_load(tmp_path: Path) -> None:
    """The commented-out mount tables, uncommented, are a valid config with those mounts."""
    text = DEFAULT_FILE.read_text()
    start = text.index("[mounts]")
    block = text[start:].split("\n\n")[0]
    uncommented = "\n".join(
        line[2:] if line.startswith("# [mounts.") or "=" in line else ""
        for line in block.splitlines()
    )
    config = load_config_from(tmp_path, uncommented.replace("# ", ""))
    assert set(config.mounts.lidars) == {"front", "rear"}
    assert config.mounts.lidars["rear"].upside_down
    assert config.mounts.gps["gnss0"].x_m == 0.3


def test_plain_dump_round_trips(tmp_path: Path) -> None:
    config = load_config_from(tmp_path, "[tcp]\ntoken = 'sixteen-chars-ok!'\nhost = '0.0.0.0'\n")
    path = tmp_path / "dumped.toml"
    path.write_text(dump_toml(config))
    assert load_config(path) == config


def load_config_from(tmp_path: Path, text: str) -> NavdConfig:
    path = tmp_path / "navd.toml"
    path.write_text(text)
    return load_config(path)


def test_missing_file(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match=r"nope\.toml: config file does not exist"):
        load_config(tmp_path / "nope.toml")


def test_directory_instead_of_file(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="is a directory, not a config file"):
        load_config(tmp_path)


def test_invalid_toml_names_the_line(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match=r"not valid TOML: .*line 2"):
        load_config_from(tmp_path, "[robot]\nradius_m = = 3\n")


def test_not_utf8(tmp_path: Path) -> None:
    path = tmp_path / "navd.toml"
    path.write_bytes(b"[robot]\nname = '\xff\xfe'\n")
    with pytest.raises(ConfigError, match="cannot be read"):
        load_config(path)


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("[planning]\nangular_limit_table = [[0.0, nan]]\n", r"angular_limit_table\.0\.1 = nan"),
        ("[planning]\nkeep_out_zones = [[[0, 0], [1, inf], [0, 1.0]]]\n", r"zones\.0\.1\.1 = inf"),
        ("[safety]\nreaction_timeout_s = nan\n", r"safety\.reaction_timeout_s = nan"),
    ],
)
def test_nan_and_infinity_are_refused_by_key(tmp_path: Path, text: str, match: str) -> None:
    with pytest.raises(ConfigError, match=rf"{match}: Input should be a finite number"):
        load_config_from(tmp_path, text)


def test_a_document_nested_thousands_deep_is_one_clear_error(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="nested too deeply to be a navd config"):
        load_config_from(tmp_path, "x = " + "[" * 3000 + "]" * 3000 + "\n")


def test_apply_changes_returns_new_config_and_changed_keys() -> None:
    old = NavdConfig()
    new, changed = apply_changes(
        old, {"safety.reaction_timeout_s": 0.25, "slam.updating_map": False}
    )
    assert changed == ("safety.reaction_timeout_s", "slam.updating_map")
    assert new.safety.reaction_timeout_s == 0.25 and not new.slam.updating_map
    assert old.safety.reaction_timeout_s == 0.5  # the old config is untouched


def test_apply_changes_accepts_a_section_table() -> None:
    new, changed = apply_changes(NavdConfig(), {"planning": {"goal_weight": 2.0}})
    assert changed == ("planning.goal_weight",) and new.planning.goal_weight == 2.0


def test_unchanged_value_reports_no_changed_keys() -> None:
    _, changed = apply_changes(NavdConfig(), {"safety.reaction_timeout_s": 0.5})
    assert changed == ()


@pytest.mark.parametrize(
    ("changes", "match"),
    [
        ({}, "must name at least one key"),
        (
            {"safety.reaction_timout_s": 1.0},
            r"safety\.reaction_timout_s: unknown key \(did you mean 'reaction_timeout_s'",
        ),
        ({"robot": 5}, r"robot: is a section; give a table of its keys"),
        ({"robot.name.first": "x"}, r"robot\.name is a value, not a section"),
        ({"robot.max_linear_speed_mps": "fast"}, r"robot\.max_linear_speed_mps = 'fast'"),
        ({"tcp.port": 9000}, r"tcp\.port: cannot change while navd runs"),
        ({"chassis.deadband": 5000}, r"chassis\.deadband \(5000\) must be below chassis\.limit"),
    ],
)
def test_bad_changes_are_rejected_whole(changes: dict[str, object], match: str) -> None:
    with pytest.raises(ConfigError, match=match):
        apply_changes(NavdConfig(), changes)


def test_one_bad_key_rejects_the_good_ones_too() -> None:
    config = NavdConfig()
    with pytest.raises(ConfigError, match=r"robot\.radius_m"):
        apply_changes(config, {"safety.reaction_timeout_s": 0.3, "robot.radius_m": -1.0})
    assert config.safety.reaction_timeout_s == 0.5
