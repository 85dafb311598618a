"""Every damaged file navd is given is one line naming the file, and exit 2: never a
traceback (the replay command, as a user types it, on files broken as they break)."""

from __future__ import annotations

import gzip
import shutil
from pathlib import Path

import pytest

from navd.cli import main
from tests.datasets import dataset

GOOD = "FLASER 3 1.0 1.5 2.0 0.0 0.0 0.0 0.0 0.0 0.0 {t} host {t}\n"


def _log(lines: int) -> str:
    return "".join(GOOD.format(t=10.0 + 0.1 * i) for i in range(lines))


def _replayed(path: Path, out: Path, capsys: pytest.CaptureFixture[str]) -> tuple[int, str]:
    code = main(["replay", str(path), "--out", str(out), "--quiet"])
    return code, capsys.readouterr().err


@pytest.mark.parametrize(
    ("name", "content", "said"),
    [
        ("one-beam.log", "FLASER 1 2.0 0 0 0 0 0 0 1.0 host 1.0\n", "1 beams"),
        ("nan-pose.log", "FLASER 3 1 1 1 0 0 0 nan 0 0 1.0 host 1.0\n", "odometry pose"),
        ("inf-stamp.clf", "FLASER 3 1 1 1 0 0 0 0 0 0 inf host 1.0\n", "must be finite"),
        ("short.log", "FLASER 3 1 1\n", "malformed FLASER line"),
        ("huge-count.log", "FLASER 99999999 1 1\n", "it says 99999999 beams, then has 2 values"),
        ("latin1.log", _log(2).encode() + "# café\n".encode("latin-1"), "not ASCII text"),
        ("empty.log", "", "holds no laser scans"),
        ("comments.log", "# a header and nothing else\n", "holds no laser scans"),
    ],
)
def test_a_broken_carmen_log_is_one_line_and_exit_2(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], name: str, content: str | bytes, said: str
) -> None:
    path = tmp_path / name
    if isinstance(content, bytes):
        path.write_bytes(content)
    else:
        path.write_text(content)
    code, err = _replayed(path, tmp_path / "out", capsys)
    assert code == 2
    assert err.count("\n") == 1 and err.startswith(f"navd replay: {path}")
    assert said in err


def test_a_gzipped_log_cut_in_half_is_one_line_and_exit_2(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    whole = gzip.compress(_log(2000).encode())
    path = tmp_path / "cut.log.gz"
    path.write_bytes(whole[: len(whole) // 2])
    code, err = _replayed(path, tmp_path / "out", capsys)
    assert code == 2
    assert err.count("\n") == 1 and err.startswith(f"navd replay: {path}")
    assert "cut short or damaged" in err


def test_a_bag_with_bytes_overwritten_is_one_line_and_exit_2(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "aces.bag"
    shutil.copy(dataset("freiburg_slam_benchmark") / "bags_ros1" / "aces.orig.bag", path)
    data = bytearray(path.read_bytes())
    middle = len(data) // 2
    data[middle : middle + 4096] = b"\xab" * 4096
    path.write_bytes(bytes(data))
    code, err = _replayed(path, tmp_path / "out", capsys)
    assert code == 2
    assert err.count("\n") == 1 and err.startswith(f"navd replay: {path}")
