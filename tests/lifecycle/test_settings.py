"""Settings derived once from the config and swapped whole on a change."""

from __future__ import annotations

from dataclasses import dataclass

import pytest

from navd.config import NavdConfig, apply_changes
from navd.lifecycle.bus import Bus
from navd.lifecycle.messages import ConfigApplied
from navd.lifecycle.module import ModuleContext
from navd.lifecycle.settings import Live, parts_of
from navd.lifecycle.workers import WorkerPool


@dataclass(frozen=True, slots=True)
class Limits:
    top_speed_mps: float

    @classmethod
    def from_config(cls, config: NavdConfig) -> Limits:
        return cls(config.robot.max_linear_speed_mps)


def _changed(config: NavdConfig, changes: dict[str, object]) -> NavdConfig:
    return apply_changes(config, changes)[0]


def test_a_change_the_settings_do_not_read_swaps_nothing() -> None:
    calls: list[tuple[Limits, Limits]] = []
    config = NavdConfig()
    live = Live(Limits.from_config, config, lambda old, new: calls.append((old, new)))
    before = live.value
    assert not live.update(_changed(config, {"planning.goal_weight": 2.0}))
    assert live.value is before and calls == []


def test_a_change_they_read_swaps_them_whole_then_calls_on_change() -> None:
    calls: list[tuple[Limits, Limits]] = []
    config = NavdConfig()
    live = Live(Limits.from_config, config, lambda old, new: calls.append((old, new)))
    assert live.update(_changed(config, {"robot.max_linear_speed_mps": 0.8}))
    assert live.value == Limits(0.8)
    assert calls == [(Limits(0.5), Limits(0.8))]


def _context(bus: Bus, config: NavdConfig, name: str = "mod") -> ModuleContext:
    return ModuleContext(
        name, bus=bus, clock=bus.clock, workers=WorkerPool(bus, threads=1), config=lambda: config
    )


def _applied(bus: Bus, config: NavdConfig) -> ConfigApplied:
    now = bus.clock.now()
    return ConfigApplied(
        stamp=now, received=now, request_id="r", changed_keys=("robot.x",), config=config
    )


def test_a_module_context_swaps_its_settings_when_a_change_is_applied(bus: Bus) -> None:
    config = NavdConfig()
    ctx = _context(bus, config)
    limits = ctx.settings(Limits.from_config)
    seen_by_handler: list[Limits] = []
    # the module's own handler runs after the swap: it already sees the new settings
    ctx.subscribe(ConfigApplied, lambda _m: seen_by_handler.append(limits.value))
    bus.publish(_applied(bus, _changed(config, {"robot.max_linear_speed_mps": 0.3})))
    assert limits.value == Limits(0.3)
    assert seen_by_handler == [Limits(0.3)]
    assert [h.name for h in ctx.holders] == ["Limits.from_config"]


def test_a_failing_on_change_counts_against_its_module_only(bus: Bus) -> None:
    config = NavdConfig()
    good = _context(bus, config, "good")
    bad = _context(bus, config, "bad")
    good_limits = good.settings(Limits.from_config)

    def refuse(old: Limits, new: Limits) -> None:
        raise RuntimeError(f"cannot take {new}")

    bad_limits = bad.settings(Limits.from_config, refuse)
    bad_after = bad.settings(
        Limits.from_config
    )  # a second holder of the failing module still swaps
    bus.publish(_applied(bus, _changed(config, {"robot.max_linear_speed_mps": 0.3})))
    assert good_limits.value == Limits(0.3)
    assert bad_limits.value == Limits(0.5)  # refused: the holder agrees with its component
    assert bad_after.value == Limits(0.3)
    assert bus.supervisor.record("bad").failures == 1
    assert bus.supervisor.record("good").failures == 0


@pytest.mark.parametrize("key", ["logging.debug", "slam.laser_x_m", "slam.min_range_m"])
def test_retired_keys_say_where_they_went(key: str) -> None:
    from navd.config import ConfigError, parse_config

    section, name = key.split(".")
    with pytest.raises(ConfigError, match=rf"{key}: (moved to lidar\.|removed)"):
        parse_config({section: {name: 0.1 if name != "debug" else True}})


def test_the_parts_of_settings_are_every_value_inside_them() -> None:
    @dataclass(frozen=True, slots=True)
    class Outer:
        limits: Limits
        pair: tuple[Limits, float]

    outer = Outer(Limits(1.0), (Limits(2.0), 3.0))
    parts = list(parts_of(outer))
    assert parts == [outer, Limits(1.0), 1.0, (Limits(2.0), 3.0), Limits(2.0), 2.0, 3.0]
