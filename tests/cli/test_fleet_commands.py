"""``navd fleet`` and ``navd demo --fleet`` refuse what they cannot do, by name, with the
exit codes the README gives (the drives themselves: tests/e2e/test_fleet_group_sim.py)."""

from __future__ import annotations

from pathlib import Path

import pytest

from navd.cli import main
from navd.sim import free_port


@pytest.mark.parametrize(
    ("argv", "code", "said"),
    [
        (["demo", "--fleet", "9"], 2, "--fleet takes 1 to 6 robots, got 9"),
        (["demo", "--fleet", "2", "--view"], 2, "drop --world, --view and --record"),
        (["fleet", "goal", "nan", "1"], 2, "x, y and heading must be finite"),
        (["fleet", "goal", "1", "1", "--heading", "inf"], 2, "x, y and heading must be finite"),
        (["fleet", "goal", "1", "1", "--spacing", "0"], 2, "spacing, step, speed and radius > 0"),
        (["fleet", "goal", "1", "1", "--radius", "-1"], 2, "spacing, step, speed and radius > 0"),
        (["fleet", "goal", "1", "1", "--map", "no-such-map.yaml"], 2, "--map: "),
        (["fleet", "status", "--broker", "http://x"], 1, "must be mqtt://HOST"),
        (
            ["fleet", "status", "--broker", f"mqtt://127.0.0.1:{free_port()}"],
            1,
            "Connection refused",
        ),
        (["fleet", "goal", "1", "1", "--broker", f"mqtt://127.0.0.1:{free_port()}"], 1, "refused"),
    ],
)
def test_fleet_commands_refuse_by_name(
    argv: list[str], code: int, said: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    if argv[0] == "demo":
        argv = [*argv, "--out", str(tmp_path)]
    assert main(argv) == code
    assert said in capsys.readouterr().err
