"""The battery's alarms: a threshold reached counts at once, one left only a margin above
it, and a reading without a charge changes nothing."""

from __future__ import annotations

import math

import pytest

from navd.config import NavdConfig
from navd.lifecycle.battery_watch import alarm_level
from navd.lifecycle.daemon_settings import BatteryLevels

LEVELS = BatteryLevels.from_config(NavdConfig())  # low 20 %, critical 10 %, margin 5 %


@pytest.mark.parametrize(
    ("charges", "alarms"),
    [
        # draining, then charging back up
        (
            [0.5, 0.21, 0.2, 0.15, 0.1, 0.12, 0.16, 0.22, 0.26],
            ["ok", "ok", "low", "low", "critical", "critical", "low", "low", "ok"],
        ),
        # a sagging voltage on the edge tells it once, not every reading
        ([0.21, 0.19, 0.21, 0.19, 0.21], ["ok", "low", "low", "low", "low"]),
        # straight from critical to full: ok
        ([0.05, 0.9], ["critical", "ok"]),
    ],
)
def test_alarms_follow_the_charge_with_a_margin_on_the_way_up(
    charges: list[float], alarms: list[str]
) -> None:
    level = "ok"
    seen = []
    for charge in charges:
        level = alarm_level(charge, level, LEVELS)  # type: ignore[arg-type]
        seen.append(level)
    assert seen == alarms


def test_the_levels_come_from_the_battery_section() -> None:
    levels = BatteryLevels.from_config(
        NavdConfig.model_validate({"battery": {"low_percent": 30, "critical_percent": 15}})
    )
    assert (levels.low, levels.critical) == (0.3, 0.15)
    assert math.isclose(LEVELS.recover, 0.05)
    with pytest.raises(ValueError, match="critical_percent"):
        NavdConfig.model_validate({"battery": {"low_percent": 10, "critical_percent": 15}})
