from __future__ import annotations

import time

import pytest

from navd.lifecycle.bus import Bus
from navd.lifecycle.clock import SimClock
from navd.lifecycle.messages import Message, SafeStop, VelocityCommand
from navd.lifecycle.supervision import Supervisor
from tests.conftest import velocity


def test_handlers_run_in_subscription_order(bus: Bus) -> None:
    calls: list[str] = []
    bus.subscribe(VelocityCommand, lambda m: calls.append("first"), module="a")
    bus.subscribe(VelocityCommand, lambda m: calls.append("second"), module="b")
    bus.subscribe(VelocityCommand, lambda m: calls.append("third"), module="a")
    bus.publish(velocity())
    assert calls == ["first", "second", "third"]


def test_messages_delivered_in_publish_order(bus: Bus) -> None:
    seen: list[float] = []
    bus.subscribe(VelocityCommand, lambda m: seen.append(m.linear_mps), module="a")
    for v in (0.1, 0.2, 0.3):
        bus.publish(velocity(v))
    assert seen == [0.1, 0.2, 0.3]


def test_publish_inside_handler_queues_behind_current_message(bus: Bus) -> None:
    """A cascade is breadth-first: every handler of message 1 runs before message 2."""
    calls: list[str] = []

    def relay(m: VelocityCommand) -> None:
        calls.append(f"relay {m.linear_mps}")
        if m.linear_mps == 1.0:
            bus.publish(velocity(2.0))

    bus.subscribe(VelocityCommand, relay, module="a")
    bus.subscribe(VelocityCommand, lambda m: calls.append(f"tail {m.linear_mps}"), module="b")
    bus.publish(velocity(1.0))
    assert calls == ["relay 1.0", "tail 1.0", "relay 2.0", "tail 2.0"]


def test_subscribing_to_base_class_receives_every_message(bus: Bus) -> None:
    everything: list[Message] = []
    only_stops: list[Message] = []
    bus.subscribe(Message, everything.append, module="recorder")
    bus.subscribe(SafeStop, only_stops.append, module="safety")
    stop = SafeStop(stamp=0.0, received=0.0, reason="test", source="t", key="t")
    bus.publish(velocity())
    bus.publish(stop)
    assert [type(m) for m in everything] == [VelocityCommand, SafeStop]
    assert only_stops == [stop]
    assert bus.dispatched == 2


def test_raising_handler_is_counted_and_does_not_stop_dispatch(bus: Bus) -> None:
    seen: list[float] = []

    def broken(m: VelocityCommand) -> None:
        raise ValueError("boom")

    bus.subscribe(VelocityCommand, broken, module="broken")
    bus.subscribe(VelocityCommand, lambda m: seen.append(m.linear_mps), module="ok")
    bus.publish(velocity(0.1))
    bus.publish(velocity(0.2))
    assert seen == [0.1, 0.2]
    assert bus.supervisor.record("broken").failures == 2
    assert bus.supervisor.record("broken").last_error == "ValueError: boom"
    assert bus.supervisor.record("ok").failures == 0


def test_repeated_failures_fault_module_and_publish_zero_velocity_once(
    bus: Bus, clock: SimClock
) -> None:
    out: list[Message] = []
    bus.subscribe(SafeStop, out.append, module="safety")
    bus.subscribe(
        VelocityCommand,
        lambda m: out.append(m) if m.source == "supervisor" else None,
        module="chassis",
    )

    def broken(m: VelocityCommand) -> None:
        if m.source == "test":
            raise RuntimeError("bad scan")

    bus.subscribe(VelocityCommand, broken, module="planner")
    for _ in range(2):  # max_failures is 3: not yet faulted
        bus.publish(velocity())
    assert out == []
    for _ in range(3):  # the 3rd failure faults; more failures do not repeat the stop
        bus.publish(velocity())
    assert [type(m) for m in out] == [SafeStop, VelocityCommand]
    stop, zero = out
    assert isinstance(stop, SafeStop) and "'planner' failed 3 times" in stop.reason
    assert isinstance(zero, VelocityCommand) and zero.is_stop
    assert set(bus.supervisor.faulted()) == {"planner"}


def test_failures_spread_beyond_the_window_do_not_fault(bus: Bus, clock: SimClock) -> None:
    def broken(m: VelocityCommand) -> None:
        raise RuntimeError("sometimes")

    bus.subscribe(VelocityCommand, broken, module="flaky")
    for _ in range(5):
        bus.publish(velocity())
        clock.advance(6.0)  # window is 10 s: at most 2 failures in any window
    assert bus.supervisor.faulted() == {}
    assert bus.supervisor.record("flaky").failures == 5


def test_cascade_bound_is_a_failure_of_the_publishing_module(clock: SimClock) -> None:
    bus = Bus(
        clock, Supervisor(max_failures=1000, window_s=1.0), handler_budget_s=10.0, max_cascade=100
    )
    delivered: list[Message] = []

    def loop_forever(m: VelocityCommand) -> None:
        bus.publish(m)
        bus.publish(m)

    bus.subscribe(VelocityCommand, loop_forever, module="runaway")
    bus.subscribe(Message, delivered.append, module="recorder")
    bus.publish(velocity())
    # the first message and the 100 its cascade may publish: 50 handler calls published
    # their two messages, and the 51 calls after them failed on their first publish
    assert len(delivered) == 101
    assert bus.supervisor.record("runaway").failures == 51
    assert "a handler is publishing in a loop" in bus.supervisor.record("runaway").last_error
    bus.publish(velocity())  # the next dispatch starts a fresh cascade
    assert len(delivered) == 202


def test_slow_handler_is_counted(clock: SimClock) -> None:
    bus = Bus(clock, Supervisor(max_failures=3, window_s=1.0), handler_budget_s=0.001)
    bus.subscribe(VelocityCommand, lambda m: time.sleep(0.003), module="slow")
    bus.subscribe(VelocityCommand, lambda m: None, module="fast")
    bus.publish(velocity())
    assert bus.supervisor.record("slow").slow_handlers == 1
    assert bus.supervisor.record("fast").slow_handlers == 0


def test_unsubscribe_module_removes_only_its_handlers(bus: Bus) -> None:
    calls: list[str] = []
    bus.subscribe(VelocityCommand, lambda m: calls.append("a"), module="a")
    bus.subscribe(VelocityCommand, lambda m: calls.append("b"), module="b")
    bus.unsubscribe_module("a")
    bus.publish(velocity())
    assert calls == ["b"]


@pytest.mark.parametrize("max_failures", [1, 4])
def test_fault_clears_after_quiet_window(max_failures: int, clock: SimClock) -> None:
    supervisor = Supervisor(max_failures=max_failures, window_s=5.0)
    newly = [supervisor.record_failure("m", clock.now(), "x") for _ in range(max_failures)]
    assert newly == [False] * (max_failures - 1) + [True]
    clock.advance(4.9)
    assert supervisor.clear_recovered(clock.now()) == []
    clock.advance(0.2)
    assert supervisor.clear_recovered(clock.now()) == ["m"]
    assert supervisor.faulted() == {}
