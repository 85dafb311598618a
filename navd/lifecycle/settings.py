"""Settings: each component's frozen values, derived once from the config and swapped whole.

A component never reads the config while it runs. It owns a settings type with a
``from_config(config)`` class method: a frozen value (plain numbers, or frozen config
sections) derived once. ``ModuleContext.settings`` registers a ``Live`` holder for it; when a
config change is applied, the module's context re-derives every holder and, for each whose
value changed, calls its ``on_change(old, new)`` on the event loop and swaps it whole, so the
component rebuilds what depends on it while its runtime state (stuck timers, filters, the
map) stays. A component that must not block the loop hands the rebuild to a worker.
``Module.settings_in_use`` reports the settings the module's parts hold now, so a test can
prove that every runtime-changeable key reaches the part that uses it.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Generic, Protocol, Self, TypeVar

from navd.config import NavdConfig

__all__ = ["Live", "Settings"]


class Settings(Protocol):
    """A frozen settings type: derived from the whole config, compared by value."""

    @classmethod
    def from_config(cls, config: NavdConfig) -> Self:
        """The settings ``config`` describes."""
        ...


S = TypeVar("S", bound=Settings)


class Live(Generic[S]):
    """The current value of one settings type, swapped whole on a config change.

    Args:
        kind: the settings type.
        config: the config at start-up.
        on_change: called with (old, new) just before a swap, on the event loop.
    """

    def __init__(
        self,
        kind: type[S],
        config: NavdConfig,
        on_change: Callable[[S, S], None] | None = None,
    ) -> None:
        self.kind = kind
        self.value: S = kind.from_config(config)
        self._on_change = on_change

    def update(self, config: NavdConfig) -> bool:
        """Re-derive from ``config``; if the value differs, call ``on_change(old, new)`` and
        then swap. An ``on_change`` that raises leaves the old value in place (the component
        and its holder never disagree), and the error goes to the caller.

        Returns:
            True if the value changed.
        """
        new = self.kind.from_config(config)
        if new == self.value:
            return False
        if self._on_change is not None:
            self._on_change(self.value, new)
        self.value = new
        return True
