"""Settings: each component's frozen values, derived once from the config and swapped whole.

A component never reads the config while it runs. Its room's ``settings`` module derives
the frozen values it runs on (plain numbers, small value types, or frozen config sections)
from the sections that concern it, with one function of the whole config: the only place
a room reads ``NavdConfig``. ``ModuleContext.settings`` registers a ``Live`` holder with that
function; when a config change is applied, the module's context re-derives every holder
and, for each whose value changed, calls its ``on_change(old, new)`` on the event loop and
swaps it whole, so the component rebuilds what depends on it while its runtime state (stuck
timers, filters, the map) stays. A component that must not block the loop hands the rebuild
to a worker. Keys that need a restart never change while the daemon runs (the config
refuses them by name), so a holder serves them as well.

``Module.settings_in_use`` reports the settings the module's parts hold now, so a test can
prove that every runtime-changeable key reaches the part that uses it: each value a part
holds must be one its holders derive from the config in force.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Iterator
from typing import Generic, TypeVar

from navd.config import NavdConfig

__all__ = ["Derive", "Live", "parts_of"]

S = TypeVar("S")
Derive = Callable[[NavdConfig], S]


class Live(Generic[S]):
    """The current value of one component's settings, swapped whole on a config change.

    Args:
        derive: the settings the config describes (a room's settings function).
        config: the config at start-up.
        on_change: called with (old, new) just before a swap, on the event loop.
    """

    def __init__(
        self,
        derive: Derive[S],
        config: NavdConfig,
        on_change: Callable[[S, S], None] | None = None,
    ) -> None:
        self.derive = derive
        self.value: S = derive(config)
        self._on_change = on_change

    @property
    def name(self) -> str:
        """What the holder holds, for logs: the function that derives it."""
        return getattr(self.derive, "__qualname__", type(self.value).__name__)

    def update(self, config: NavdConfig) -> bool:
        """Re-derive from ``config``; if the value differs, call ``on_change(old, new)`` and
        then swap. An ``on_change`` that raises leaves the old value in place (the component
        and its holder never disagree), and the error goes to the caller.

        Returns:
            True if the value changed.
        """
        new = self.derive(config)
        if new == self.value:
            return False
        if self._on_change is not None:
            self._on_change(self.value, new)
        self.value = new
        return True


def parts_of(settings: object) -> Iterator[object]:
    """``settings`` and every frozen value inside it (the fields of dataclasses, the items
    of tuples), depth first: the parts a component's settings are made of."""
    yield settings
    if dataclasses.is_dataclass(settings) and not isinstance(settings, type):
        for field in dataclasses.fields(settings):
            yield from parts_of(getattr(settings, field.name))
    elif isinstance(settings, tuple):
        for item in settings:
            yield from parts_of(item)
