"""Privileges by effect: a control client without tcp.allow_privileged_changes may change
only the operator keys (reports, records, route preferences); every other key of the model
is refused by name, the ones that once slipped through among them."""

from __future__ import annotations

import pytest

from navd.config import ConfigError, NavdConfig
from navd.config.fields import OPERATOR_KEYS, restart_required
from navd.config.loader import apply_changes, check_unprivileged


def _runtime_keys() -> list[str]:
    keys = []
    for section, field in NavdConfig.model_fields.items():
        model = field.annotation
        assert model is not None
        keys += [
            f"{section}.{name}"
            for name in model.model_fields  # type: ignore[union-attr]
            if not restart_required(model, name)  # type: ignore[arg-type]
        ]
    return keys


def test_every_operator_key_is_a_key_of_the_model_that_can_change_at_run_time() -> None:
    runtime = set(_runtime_keys())
    named = {f"{s}.{k}" for s, keys in OPERATOR_KEYS.items() for k in keys}
    assert named - runtime == set()


@pytest.mark.parametrize("key", _runtime_keys())
def test_each_key_outside_the_operator_list_is_refused_without_the_right(key: str) -> None:
    section, name = key.split(".")
    if name in OPERATOR_KEYS.get(section, frozenset()):
        check_unprivileged((key,), source="test")  # taken
    else:
        with pytest.raises(ConfigError, match=rf"{key}: a privileged key"):
            check_unprivileged((key,), source="test")


@pytest.mark.parametrize(
    ("key", "value"),
    [
        ("slam.lost_after_scans", 0),
        ("viz.untokened_commands", True),
        ("fleet.on_broker_lost", "continue"),
        ("planning.obstacle_persistence_s", 0.0),
        ("planning.inflation_radius_m", 0.0),
        ("estimation.lidar_gate_chi2", 1000.0),
        ("battery.critical_percent", 1.0),
    ],
)
def test_keys_that_make_the_robot_less_safe_need_the_right(key: str, value: object) -> None:
    with pytest.raises(ConfigError, match="a privileged key"):
        apply_changes(NavdConfig(), {key: value}, may_change_privileged=False)
    _, changed = apply_changes(NavdConfig(), {key: value}, may_change_privileged=True)
    assert changed == (key,)


def test_an_operator_key_changes_without_the_right() -> None:
    new, changed = apply_changes(
        NavdConfig(), {"planning.goal_xy_tolerance_m": 0.2}, may_change_privileged=False
    )
    assert changed == ("planning.goal_xy_tolerance_m",)
    assert new.planning.goal_xy_tolerance_m == 0.2
