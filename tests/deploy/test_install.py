"""deploy/install.sh staged into a temporary root, and the unit it installs."""

from __future__ import annotations

import hashlib
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
INSTALL = REPO / "deploy" / "install.sh"


@pytest.fixture(scope="session")
def wheel(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("wheel")
    subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "--quiet", "--no-deps", "-w", str(out), str(REPO)],
        check=True,
        capture_output=True,
        timeout=300,
    )
    (built,) = out.glob("navd-*.whl")
    return built


def install(root: Path, wheel: Path, *extra: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [
            "bash",
            str(INSTALL),
            "--destdir",
            str(root),
            "--source",
            str(wheel),
            "--python",
            sys.executable,
            "--pip-args",
            "--no-deps --no-index",
            *extra,
        ],
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
    )


def uninstall(root: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        ["bash", str(INSTALL), "--destdir", str(root), "--uninstall"],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )


def snapshot(root: Path) -> dict[str, str]:
    """Every path under root; files outside the virtual environment with their hash."""
    out = {}
    for path in sorted(root.rglob("*")):
        rel = str(path.relative_to(root))
        if path.is_file() and "/venv/" not in rel:
            out[rel] = hashlib.sha256(path.read_bytes()).hexdigest()
        elif "__pycache__" not in rel:
            out[rel] = "dir" if path.is_dir() else "file"
    return out


def test_install_tree_idempotent_and_keeps_an_edited_config(tmp_path: Path, wheel: Path) -> None:
    root = tmp_path / "root"
    first = install(root, wheel)
    assert first.returncode == 0, first.stderr
    assert (root / "opt/navd/venv/bin/navd").exists()
    assert (root / "etc/navd/navd.toml").read_text() == (REPO / "config/navd.toml").read_text()
    unit = (root / "etc/systemd/system/navd.service").read_text()
    assert "ExecStart=/opt/navd/venv/bin/navd run --config /etc/navd/navd.toml" in unit
    assert (root / "var/lib/navd").is_dir()
    sensor_unit = (root / "etc/systemd/system/navd-sensor@.service").read_text()
    assert "ExecStart=/opt/navd/venv/bin/navd sensor ${KIND} --port ${PORT}" in sensor_unit
    assert "EnvironmentFile=/etc/navd/sensors/%i.env" in sensor_unit
    assert (root / "etc/navd/sensors").is_dir()
    assert (root / "opt/navd/share/navd/installed").read_text().split() == [
        "/etc/systemd/system/navd.service",
        "/etc/systemd/system/navd-sensor@.service",
        "/opt/navd/venv",
        "/opt/navd/share/navd/navd.toml.default",
        "/opt/navd/share/navd/installed",
    ]
    before = snapshot(root)
    second = install(root, wheel)
    assert second.returncode == 0, second.stderr
    assert snapshot(root) == before  # idempotent

    config = root / "etc/navd/navd.toml"
    config.write_text(
        config.read_text().replace("reaction_timeout_s = 0.5", "reaction_timeout_s = 0.4")
    )
    third = install(root, wheel)
    assert "kept your /etc/navd/navd.toml" in third.stdout
    assert "reaction_timeout_s = 0.4" in config.read_text()
    assert not (root / "etc/navd/navd.toml.new").exists()  # the shipped default is unchanged

    default_copy = root / "opt/navd/share/navd/navd.toml.default"
    default_copy.write_text("# an older default\n")  # as if the shipped default changed
    fourth = install(root, wheel)
    assert "navd.toml.new" in fourth.stdout
    assert (root / "etc/navd/navd.toml.new").read_text() == (REPO / "config/navd.toml").read_text()
    assert "reaction_timeout_s = 0.4" in config.read_text()


def test_uninstall_removes_what_it_installed_and_nothing_else(tmp_path: Path, wheel: Path) -> None:
    root = tmp_path / "root"
    (root / "etc").mkdir(parents=True)
    (root / "etc/hostname").write_text("robot\n")
    assert install(root, wheel).returncode == 0
    (root / "var/lib/navd/maps").mkdir()
    (root / "var/lib/navd/maps/office.yaml").write_text("image: office.pgm\n")
    config = root / "etc/navd/navd.toml"
    config.write_text(config.read_text() + "# my robot\n")
    result = uninstall(root)
    assert result.returncode == 0, result.stderr
    assert "kept your edited /etc/navd/navd.toml" in result.stdout
    assert not (root / "opt/navd").exists()
    assert not (root / "etc/systemd/system/navd.service").exists()
    assert not (root / "etc/systemd/system/navd-sensor@.service").exists()
    assert config.read_text().endswith("# my robot\n")
    assert (root / "var/lib/navd/maps/office.yaml").exists()
    assert (root / "etc/hostname").read_text() == "robot\n"


def test_uninstall_of_an_unedited_install_leaves_no_trace(tmp_path: Path, wheel: Path) -> None:
    root = tmp_path / "root"
    assert install(root, wheel).returncode == 0
    result = uninstall(root)
    assert result.returncode == 0, result.stderr
    leftovers = [str(p.relative_to(root)) for p in root.rglob("*") if p.is_file()]
    assert leftovers == []


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--prefix", "relative/path", "--no-system"], "--prefix must be an absolute path"),
        (["--bogus"], "unknown option '--bogus'"),
        (["--uninstall", "--destdir", "/nonexistent-navd-root"], "nothing to uninstall"),
    ],
)
def test_bad_invocations_say_what_is_wrong(args: list[str], message: str) -> None:
    result = subprocess.run(
        ["bash", str(INSTALL), *args], capture_output=True, text=True, timeout=60, check=False
    )
    assert result.returncode == 1
    assert message in result.stderr


@pytest.mark.skipif(
    shutil.which("systemd-analyze") is None,
    reason="systemd-analyze is not installed (make test installs it as root)",
)
@pytest.mark.parametrize(
    ("installed", "checked"),
    [("navd.service", "navd.service"), ("navd-sensor@.service", "navd-sensor@lidar0.service")],
)
def test_installed_units_pass_systemd_analyze_verify(
    tmp_path: Path, wheel: Path, installed: str, checked: str
) -> None:
    root = tmp_path / "root"
    assert install(root, wheel).returncode == 0
    # verify checks that ExecStart exists: point it at the staged binary, change nothing else
    unit = (root / "etc/systemd/system" / installed).read_text()
    staged = tmp_path / checked  # a template is verified as one of its instances
    staged.write_text(unit.replace("/opt/navd/venv/bin/navd", f"{root}/opt/navd/venv/bin/navd"))
    result = subprocess.run(
        ["systemd-analyze", "verify", str(staged)],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip() == "" and result.stderr.strip() == ""  # no warnings either
