from __future__ import annotations

import tomllib
from pathlib import Path

import numpy as np
import pytest

from navd import __version__
from navd.cli import main
from navd.geometry import IDENTITY, scan_points
from navd.slam import OccupancyGrid, save_map

DEFAULT_FILE = Path(__file__).resolve().parents[1] / "config" / "navd.toml"


def _broken_copy(tmp_path: Path, old: str, new: str) -> Path:
    text = DEFAULT_FILE.read_text()
    assert old in text
    path = tmp_path / "navd.toml"
    path.write_text(text.replace(old, new, 1))
    return path


def test_check_accepts_the_default_file(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["config", "check", str(DEFAULT_FILE)]) == 0
    assert capsys.readouterr().out.strip().endswith("navd.toml: ok")


@pytest.mark.parametrize(
    ("old", "new", "named"),
    [
        (
            "max_linear_speed_mps = 0.5",
            "max_linear_sped_mps = 0.5",
            "robot.max_linear_sped_mps: unknown key (did you mean 'max_linear_speed_mps'?)",
        ),
        (
            "max_linear_speed_mps = 0.5",
            "max_linear_speed_mps = -0.5",
            "robot.max_linear_speed_mps = -0.5: Input should be greater than 0",
        ),
        (
            "radius_m = 0.2",
            'radius_m = "0.2"',
            "robot.radius_m = '0.2': Input should be a valid number",
        ),
    ],
)
def test_check_rejects_a_bad_copy_naming_the_key(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], old: str, new: str, named: str
) -> None:
    assert main(["config", "check", str(_broken_copy(tmp_path, old, new))]) == 2
    assert named in capsys.readouterr().err


def test_check_reads_the_files_the_config_names_as_the_daemon_would(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    grid = OccupancyGrid(0.05)
    grid.insert(
        IDENTITY, scan_points(np.full(90, 2.0), -np.pi, np.pi / 45, range_min=0.1, range_max=8.0)
    )
    save_map(grid, tmp_path / "maps", "office")
    (tmp_path / "maps" / "broken.yaml").write_text("image: nowhere.pgm\n")
    monkeypatch.chdir(tmp_path)  # relative paths are read from where navd runs
    path = tmp_path / "navd.toml"
    path.write_text('[slam]\nload_map = "maps/office.yaml"\n')
    assert main(["config", "check", str(path)]) == 0
    assert capsys.readouterr().out.strip().endswith("navd.toml: ok")
    path.write_text(
        '[slam]\nload_map = "maps/broken.yaml"\n'
        '[planning]\nkeep_out_mask = "zones/keep_out.yaml"\n'
        '[fleet]\nenabled = true\nbroker_url = "mqtts://broker:8883"\n'
        'ca_file = "/no/such/ca.pem"\n'
    )
    assert main(["config", "check", str(path)]) == 2
    err = capsys.readouterr().err
    assert "3 problems" in err
    assert "slam.load_map: " in err and "broken.yaml" in err
    assert "planning.keep_out_mask: " in err and "keep_out.yaml" in err
    assert f"read from {tmp_path}" in err  # a relative path says where it was looked for
    assert "fleet.ca_file: /no/such/ca.pem: cannot be read" in err
    # The fleet off opens no TLS file (the daemon would not either).
    path.write_text(path.read_text().replace("enabled = true", "enabled = false"))
    assert main(["config", "check", str(path)]) == 2
    assert "2 problems" in capsys.readouterr().err
    # A config for another machine: its keys alone; or its files read from where navd runs.
    assert main(["config", "check", "--keys-only", str(path)]) == 0
    path.write_text('[slam]\nload_map = "maps/office.yaml"\n')
    monkeypatch.chdir(tmp_path / "maps")
    assert main(["config", "check", str(path)]) == 2
    assert f"read from {tmp_path / 'maps'}" in capsys.readouterr().err
    assert main(["config", "check", str(path), "--from", str(tmp_path)]) == 0
    assert main(["config", "check", str(path), "--from", str(tmp_path), "--keys-only"]) == 2
    assert "--keys-only reads none" in capsys.readouterr().err


def test_dump_fills_defaults(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "navd.toml"
    path.write_text("[safety]\nreaction_timeout_s = 0.3\n")
    assert main(["config", "dump", "--config", str(path)]) == 0
    dumped = tomllib.loads(capsys.readouterr().out)
    assert dumped["safety"]["reaction_timeout_s"] == 0.3
    assert dumped["robot"]["max_linear_speed_mps"] == 0.5


def test_dump_with_comments_is_the_default_file(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["config", "dump", "--comments"]) == 0
    assert capsys.readouterr().out == DEFAULT_FILE.read_text()


def test_run_with_a_bad_config_exits_2_before_starting(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "navd.toml"
    path.write_text("[tcp]\nport = 'http'\n")
    assert main(["run", "--config", str(path)]) == 2
    assert "tcp.port = 'http'" in capsys.readouterr().err


def test_version(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as info:
        main(["--version"])
    assert info.value.code == 0
    assert capsys.readouterr().out.strip() == f"navd {__version__}"


def test_no_command_prints_help_and_exits_2(capsys: pytest.CaptureFixture[str]) -> None:
    assert main([]) == 2
    assert "usage: navd" in capsys.readouterr().err


def test_bench_estimation_reports_a_clean_run(capsys: pytest.CaptureFixture[str]) -> None:
    import json

    assert main(["bench", "estimation", "--seconds", "3", "--json"]) == 0
    figures = json.loads(capsys.readouterr().out)
    assert figures["ukf_resets"] == 0
    assert figures["ukf_steps"] == 29  # 10 Hz for 3 s; the first pose starts the filter
    # Every lidar pose is 100 ms late, behind about five 50 Hz wheel events.
    assert figures["late_events"] == 29
    assert 3.0 <= figures["events_reapplied_per_late_event"] <= 6.0
    assert figures["madgwick_us_per_sample"] > 0.0


def test_bench_output_on_stdout_is_pure_json_even_when_the_estimator_logs(
    capsys: pytest.CaptureFixture[str],
) -> None:
    import json

    from navd.logs import get_logger

    assert main(["bench", "estimation", "--seconds", "2", "--json"]) == 0
    get_logger("test").warning("after the figures")  # lands on stderr, not in the JSON
    captured = capsys.readouterr()
    json.loads(captured.out)
    assert "after the figures" in captured.err
