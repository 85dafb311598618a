"""Errors raised by navd.lifecycle."""

from __future__ import annotations

from navd.errors import NavdError

__all__ = [
    "DispatchError",
    "LifecycleError",
    "MessageError",
    "ModuleStateError",
    "ModuleTimeoutError",
]


class LifecycleError(NavdError):
    """Base of the errors raised by navd.lifecycle."""


class MessageError(LifecycleError, ValueError):
    """A message was built with a value that is always wrong (the message names the field)."""


class ModuleTimeoutError(LifecycleError):
    """A module did not finish a lifecycle transition within its timeout."""

    def __init__(self, module: str, transition: str, timeout_s: float) -> None:
        super().__init__(
            f"module {module!r} did not finish {transition} within {timeout_s:g} s; "
            f"it is hung (raise lifecycle.transition_timeout_s if it is only slow)"
        )
        self.module = module
        self.transition = transition
        self.timeout_s = timeout_s


class ModuleStateError(LifecycleError):
    """A lifecycle transition was asked for in a state that does not allow it."""


class DispatchError(LifecycleError):
    """Handlers published more messages in one cascade than the bound allows."""
