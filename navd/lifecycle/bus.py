"""The message bus: modules subscribe handlers per message type and publish messages.

Dispatch order is deterministic: messages are delivered in the order they were published,
and the handlers of one message in the order they subscribed. A handler that publishes does
not recurse into other handlers: its messages queue behind the current one (a trampoline),
so every handler sees a consistent world and a cascade is bounded.

Handlers run on the event loop and must be cheap. The bus is the one supervised boundary:
an exception in a handler is logged with the message that caused it and counted against the
handler's module; repeated failures make the robot safe (a zero VelocityCommand and a
SafeStop are published). Subscribing to ``Message`` receives every message.

The bus is not thread-safe: worker threads hand results back with
``loop.call_soon_threadsafe(bus.publish, message)`` (see ``WorkerPool``).
"""

from __future__ import annotations

import time
from collections import deque
from collections.abc import Callable
from typing import Any, TypeVar

from navd.lifecycle.clock import Clock
from navd.lifecycle.errors import DispatchError
from navd.lifecycle.messages import Message, SafeStop, VelocityCommand, describe
from navd.lifecycle.supervision import Supervisor
from navd.logs import get_logger

__all__ = ["Bus", "Handler"]

M = TypeVar("M", bound=Message)
Handler = Callable[[M], None]

_log = get_logger("lifecycle.bus")


class Bus:
    """Typed publish/subscribe on the event loop, with supervision.

    Args:
        clock: the daemon clock (stamps of the safety messages the bus publishes).
        supervisor: failure bookkeeping.
        handler_budget_s: [s] a handler taking longer is counted as slow and logged.
        max_cascade: most messages handlers may publish while one dispatch runs; beyond it
            publishing raises DispatchError (a handler publishing in a loop), so every cascade
            ends and the queue stays bounded.
    """

    def __init__(
        self,
        clock: Clock,
        supervisor: Supervisor,
        *,
        handler_budget_s: float = 0.001,
        max_cascade: int = 10_000,
    ) -> None:
        self.clock = clock
        self.supervisor = supervisor
        self.handler_budget_s = handler_budget_s
        self.max_cascade = max_cascade
        self.dispatched = 0
        self._subscriptions: dict[type[Message], list[tuple[str, Callable[[Any], None]]]] = {}
        self._routes: dict[type[Message], list[tuple[str, Callable[[Any], None]]]] = {}
        self._pending: deque[Message] = deque()
        self._dispatching = False
        self._cascade = 0

    def subscribe(self, message_type: type[M], handler: Handler[M], *, module: str) -> None:
        """Call ``handler`` for every published message of ``message_type`` (or a subclass).

        Args:
            message_type: the message class; ``Message`` receives everything.
            handler: a cheap function of the message, run on the event loop.
            module: the module the handler belongs to (its failures count against it).
        """
        self._subscriptions.setdefault(message_type, []).append((module, handler))
        self._routes.clear()

    def unsubscribe_module(self, module: str) -> None:
        """Remove every handler of ``module`` (when it is deactivated)."""
        for message_type, subs in self._subscriptions.items():
            self._subscriptions[message_type] = [s for s in subs if s[0] != module]
        self._routes.clear()

    def publish(self, message: Message) -> None:
        """Deliver ``message`` to its handlers, after the messages already queued.

        Raises:
            DispatchError: handlers published more than ``max_cascade`` messages in this
                cascade (only ever inside a handler, where the bus counts it as that handler's
                failure).
        """
        if self._dispatching:
            self._cascade += 1
            if self._cascade > self.max_cascade:
                raise DispatchError(
                    f"dispatch cascade exceeded {self.max_cascade} messages published by handlers "
                    f"while publishing {type(message).__name__}: a handler is publishing in a loop"
                )
        self._enqueue(message)

    def _enqueue(self, message: Message) -> None:
        """Queue and, unless a dispatch is already running, deliver; never refuses."""
        self._pending.append(message)
        if self._dispatching:
            return
        self._dispatching = True
        self._cascade = 0
        try:
            while self._pending:
                self._deliver(self._pending.popleft())
        finally:
            self._dispatching = False

    def report_failure(self, module: str, context: dict[str, object], error: BaseException) -> None:
        """Log and count a failure of ``module``; make the robot safe if it is now faulted.

        Used by the bus for handlers and by the worker pool for jobs.
        """
        now = self.clock.now()
        _log.error(
            "handler_failed",
            module=module,
            error=f"{type(error).__name__}: {error}",
            exc_info=error,
            **context,
        )
        if self.supervisor.record_failure(module, now, f"{type(error).__name__}: {error}"):
            reason = (
                f"module {module!r} failed {self.supervisor.max_failures} times within "
                f"{self.supervisor.window_s:g} s (last: {type(error).__name__}: {error})"
            )
            _log.error("module_faulted", module=module, reason=reason)
            # Safety messages bypass the cascade bound: they must never be refused.
            self._enqueue(
                SafeStop(
                    stamp=now,
                    received=now,
                    reason=reason,
                    source="supervisor",
                    key=f"fault:{module}",
                )
            )
            self._enqueue(
                VelocityCommand(
                    stamp=now, received=now, linear_mps=0.0, angular_radps=0.0, source="supervisor"
                )
            )

    def _route(self, message_type: type[Message]) -> list[tuple[str, Callable[[Any], None]]]:
        route = self._routes.get(message_type)
        if route is None:
            route = []
            for cls in reversed(message_type.__mro__):
                route.extend(self._subscriptions.get(cls, ()))
            self._routes[message_type] = route
        return route

    def _deliver(self, message: Message) -> None:
        self.dispatched += 1
        for module, handler in self._route(type(message)):
            started = time.perf_counter()
            try:
                handler(message)
            except Exception as err:  # the one supervised boundary: log, count, make safe
                self.report_failure(
                    module,
                    {"handler": _name(handler), "message": describe(message)},
                    err,
                )
            elapsed = time.perf_counter() - started
            if elapsed > self.handler_budget_s:
                self.supervisor.record_slow(module)
                slow = self.supervisor.record(module).slow_handlers
                if slow == 1 or slow % 100 == 0:
                    _log.warning(
                        "slow_handler",
                        module=module,
                        handler=_name(handler),
                        message_type=type(message).__name__,
                        elapsed_ms=round(elapsed * 1e3, 3),
                        budget_ms=self.handler_budget_s * 1e3,
                        slow_count=slow,
                    )


def _name(handler: Callable[..., object]) -> str:
    return getattr(handler, "__qualname__", repr(handler))
