"""Every key that may change while navd runs reaches the part that uses it, on a running
daemon with every module (the chassis on a real pseudo-terminal, clients on real sockets).

For each runtime key: a valid new value is sent as a config change over TCP; then every
settings value each module's parts hold (``settings_in_use``, read back from the parts) must
equal what its type derives from the config now, and at least one of them must have changed
(a key nobody uses must be marked "needs a restart" or removed).
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import pytest
from pydantic import BaseModel

from navd.config import ConfigError, NavdConfig, apply_changes
from navd.config.fields import restart_required
from navd.estimation import EstimationNode
from navd.lifecycle import Daemon, parts_of
from navd.lifecycle.messages import PoseMeasurement
from navd.sim import free_port
from navd.slam import SlamNode
from navd.wire import ConfigAppliedFrame, ConfigFrame, ConfigRejectedFrame
from tests.conftest import room_scan
from tests.drivers.conftest import connected, record, running_daemon, until

# Keys changed together with their partner (the model requires them as a pair).
PAIRS = {
    "world.datum_latitude_deg": {"world.datum_longitude_deg": 13.405},
    "world.datum_longitude_deg": {"world.datum_latitude_deg": 52.52},
}
# Keys used only when another key says so: that key is set first.
CONTEXT = {
    "robot.radius_m": {"robot.footprint": "circle"},
    "robot.length_m": {"robot.footprint": "rectangle"},
    "robot.width_m": {"robot.footprint": "rectangle"},
}
SPECIAL: dict[str, list[Any]] = {
    "planning.angular_limit_table": [[[0.0, 1.4], [0.5, 0.7]]],
    "planning.keep_out_zones": [[[[5.0, 5.0], [6.0, 5.0], [6.0, 6.0]]]],
    "world.datum_latitude_deg": [52.52, 48.0],
    "world.datum_longitude_deg": [13.405, 11.5],
    "world.utm_zone": [33],
}


def runtime_keys() -> list[str]:
    """Every dotted key the model lets change at runtime, in model order."""
    keys = []
    for section, field in NavdConfig.model_fields.items():
        model = field.annotation
        assert isinstance(model, type) and issubclass(model, BaseModel)
        keys += [
            f"{section}.{name}" for name in model.model_fields if not restart_required(model, name)
        ]
    return keys


def _candidates(config: NavdConfig, key: str) -> list[Any]:
    if key in SPECIAL:
        return SPECIAL[key]
    section, name = key.split(".")
    value = getattr(getattr(config, section), name)
    field = type(getattr(config, section)).model_fields[name]
    if isinstance(value, bool):
        return [not value]
    if isinstance(value, int):
        return [value + 1, value - 1]
    if isinstance(value, float):
        return [value * 1.25, value * 0.8, value + 0.1, value - 0.1]
    if isinstance(value, str):
        options = getattr(field.annotation, "__args__", ())
        return [o for o in options if o != value] or [f"{value}-2"]
    if value is None:
        return [field.examples[0]] if field.examples else [1.0]
    raise AssertionError(f"{key}: no candidate values for a {type(value).__name__}")


def change_for(config: NavdConfig, key: str) -> dict[str, Any]:
    """A valid change of ``key`` (with its partner, if it has one) from ``config``."""
    for value in _candidates(config, key):
        changes = {key: value, **PAIRS.get(key, {})}
        try:
            _, changed = apply_changes(config, changes)
        except ConfigError:
            continue
        if key in changed:
            return changes
    raise AssertionError(f"{key}: found no valid new value; add one to SPECIAL")


def in_use(daemon: Daemon) -> dict[str, tuple[object, ...]]:
    """The settings every module's parts (and the daemon's own) hold now."""
    held = {"daemon": daemon.settings_in_use()}
    held.update({m.name: m.settings_in_use() for m in daemon.manager.modules})
    return held


def derived(daemon: Daemon, owner: str) -> list[object]:
    """Every value ``owner``'s settings holders derive from the config in force, with the
    parts inside them: what its parts may hold."""
    config = daemon.config
    if owner == "daemon":
        holders = [daemon.lifecycle, daemon.logging]
    else:
        holders = list(daemon.manager.contexts[owner].holders)
    return [part for live in holders for part in parts_of(live.derive(config))]


def test_the_walk_covers_the_keys_users_tune() -> None:
    keys = runtime_keys()
    assert len(keys) > 100
    for key in ("planning.control_rate_hz", "chassis.command_rate_hz", "logging.level"):
        assert key in keys
    for key in ("tcp.port", "slam.load_map", "lifecycle.worker_threads", "chassis.port"):
        assert key not in keys


async def test_every_runtime_key_reaches_the_part_that_uses_it(tmp_path: Path) -> None:
    master, slave = os.openpty()
    link = tmp_path / "ttyNAVD"
    link.symlink_to(os.ttyname(slave))
    sections: dict[str, dict[str, Any]] = {
        "chassis": {"enabled": True, "port": str(link)},
        "slam": {"map_dir": str(tmp_path / "maps")},
        "tcp": {"allow_privileged_changes": True},  # every key, privileged ones too
        # the fleet module, its broker nowhere (it keeps trying, as on a robot off the network)
        "fleet": {"enabled": True, "broker_url": f"mqtt://127.0.0.1:{free_port()}"},
    }
    try:
        async with running_daemon(**sections) as (daemon, port):
            poses = record(daemon, PoseMeasurement)
            lidar = await connected(port, "lidar", "lidar0")
            control = await connected(port, "control", "ui")
            for i in range(3):  # scan odometry exists once scans came without wheels
                lidar.send(room_scan(1.0 + 0.1 * i))
                await until(lambda n=i: len(poses) > n, timeout_s=10.0)
            await until(
                lambda: all(
                    m.estimator is not None
                    for m in daemon.manager.modules
                    if isinstance(m, EstimationNode)
                ),
                timeout_s=10.0,
            )
            assert any(isinstance(m, SlamNode) and m._scan_odometry for m in daemon.manager.modules)
            unused = []
            for key in runtime_keys():
                if key in CONTEXT:
                    control.send(ConfigFrame(changes=CONTEXT[key]))
                    await control.receive_type(ConfigAppliedFrame | ConfigRejectedFrame)
                before = in_use(daemon)
                control.send(ConfigFrame(changes=change_for(daemon.config, key)))
                answer = await control.receive_type(ConfigAppliedFrame | ConfigRejectedFrame)
                assert isinstance(answer, ConfigAppliedFrame), f"{key}: {answer}"
                assert key in answer.changed
                await daemon.workers.wait_idle()  # changes a worker applies between jobs
                after = in_use(daemon)
                for owner, held in after.items():
                    expected = derived(daemon, owner)
                    for settings in held:
                        assert any(type(e) is type(settings) for e in expected), (
                            f"{owner} holds a {type(settings).__name__} no holder of it derives"
                        )
                        assert settings in expected, (
                            f"after {key}: {owner} holds a stale {type(settings).__name__}"
                        )
                if after == before:
                    unused.append(key)
            assert unused == [], f"no part uses {unused}: use them, or mark them needs a restart"
            await lidar.close()
            await control.close()
    finally:
        os.close(master)
        os.close(slave)


@pytest.mark.parametrize("key", ["tcp.port", "lifecycle.worker_threads", "slam.load_map"])
def test_keys_that_need_a_restart_are_refused_by_name(key: str) -> None:
    value = {"tcp.port": 9000, "lifecycle.worker_threads": 3, "slam.load_map": "maps/x.yaml"}[key]
    with pytest.raises(ConfigError, match=rf"{key}: cannot change while navd runs"):
        apply_changes(NavdConfig(), {key: value})
