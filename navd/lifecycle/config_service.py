"""The running config: replaced whole by validated changes, never half-changed.

A ConfigChange message goes through the same pydantic model as the file. It is applied
whole (ConfigApplied, carrying the new config) or rejected whole (ConfigRejected, with every
bad key named); this is the seed's ConfigProperty model.
"""

from __future__ import annotations

from pathlib import Path

from navd.config import (
    ConfigError,
    NavdConfig,
    apply_changes,
    changed_keys,
    check_runtime_changeable,
    load_config,
)
from navd.lifecycle.bus import Bus
from navd.lifecycle.clock import Clock
from navd.lifecycle.messages import ConfigApplied, ConfigChange, ConfigRejected
from navd.logs import get_logger

__all__ = ["ConfigService"]

_log = get_logger("lifecycle.config")


class ConfigService:
    """Holds the config in force and applies changes to it.

    Args:
        bus: where answers are published; the service subscribes to ConfigChange.
        clock: stamps of the answers.
        config: the config at start-up.
    """

    MODULE = "config"

    def __init__(self, bus: Bus, clock: Clock, config: NavdConfig) -> None:
        self._bus = bus
        self._clock = clock
        self._config = config
        bus.subscribe(ConfigChange, self.handle_change, module=self.MODULE)

    @property
    def current(self) -> NavdConfig:
        """The config in force."""
        return self._config

    def handle_change(self, change: ConfigChange) -> None:
        """Apply a ConfigChange whole, or reject it whole with the reason."""
        try:
            new, changed = apply_changes(
                self._config, change.changes, may_change_privileged=change.privileged
            )
        except ConfigError as err:
            self._reject(change.request_id, change.source, err)
            return
        self._install(new, changed, change.request_id, change.source)

    def reload(self, path: Path, request_id: str = "reload") -> bool:
        """Replace the config by the file at ``path`` (SIGHUP); True if applied.

        Keys that need a restart must keep their value, or the whole reload is rejected.
        """
        try:
            new = load_config(path)
            changed = changed_keys(self._config, new)
            check_runtime_changeable(changed, source=str(path))
        except ConfigError as err:
            self._reject(request_id, str(path), err)
            return False
        self._install(new, changed, request_id, str(path))
        return True

    def _install(
        self, new: NavdConfig, changed: tuple[str, ...], request_id: str, source: str
    ) -> None:
        self._config = new
        _log.info("config_applied", request_id=request_id, source=source, changed=changed)
        now = self._clock.now()
        self._bus.publish(
            ConfigApplied(
                stamp=now, received=now, request_id=request_id, changed_keys=changed, config=new
            )
        )

    def _reject(self, request_id: str, source: str, err: ConfigError) -> None:
        _log.warning(
            "config_rejected", request_id=request_id, source=source, problems=list(err.problems)
        )
        now = self._clock.now()
        self._bus.publish(
            ConfigRejected(stamp=now, received=now, request_id=request_id, reason=str(err))
        )
