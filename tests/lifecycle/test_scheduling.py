"""The event-loop thread's time slice: asked of the kernel per thread, and nothing asked
where there is no such call."""

from __future__ import annotations

import os
import threading

import pytest

from navd.config import ConfigError, parse_config
from navd.lifecycle import scheduling
from navd.lifecycle.scheduling import request_slice, thread_slice_s


def _in_a_thread(job):  # type: ignore[no-untyped-def]
    out = []
    thread = threading.Thread(target=lambda: out.append(job()))
    thread.start()
    thread.join(5.0)
    return out[0]


def test_a_thread_gets_the_slice_it_asks_for_and_the_others_keep_theirs() -> None:
    if thread_slice_s() is None:
        pytest.skip("this kernel gives no task a slice of its own (Linux 6.12 and later do)")
    here = thread_slice_s()

    def ask() -> tuple[bool, float | None]:
        return request_slice(0.0004), thread_slice_s()

    assert _in_a_thread(ask) == (True, pytest.approx(0.0004))
    assert thread_slice_s() == here  # a thread's own, not the process's


def test_a_thread_under_another_policy_is_left_as_it_is() -> None:
    if thread_slice_s() is None:
        pytest.skip("this kernel gives no task a slice of its own (Linux 6.12 and later do)")

    def batch_then_ask() -> tuple[bool, int]:
        os.sched_setscheduler(0, os.SCHED_BATCH, os.sched_param(0))  # this thread only
        return request_slice(0.0004), os.sched_getscheduler(0)

    assert _in_a_thread(batch_then_ask) == (False, os.SCHED_BATCH)


def test_nothing_is_asked_where_there_is_no_such_call(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(scheduling, "_syscall", lambda: None)
    assert request_slice(0.0003) is False
    assert thread_slice_s() is None
    monkeypatch.setattr(scheduling.platform, "machine", lambda: "riscv64")
    never = lambda *_: pytest.fail("a call made on a machine without one")  # noqa: E731
    monkeypatch.setattr(scheduling, "_syscall", lambda: never)
    assert request_slice(0.0003) is False
    assert thread_slice_s() is None


@pytest.mark.parametrize("slice_ms", [0.0, 0.1, 0.3, 100.0])
def test_the_loop_slice_is_0_or_one_the_kernel_can_give(slice_ms: float) -> None:
    config = parse_config({"lifecycle": {"loop_slice_ms": slice_ms}})
    assert config.lifecycle.loop_slice_ms == slice_ms


@pytest.mark.parametrize("slice_ms", [0.05, -1.0, 150.0])
def test_a_loop_slice_the_kernel_cannot_give_is_refused_by_name(slice_ms: float) -> None:
    with pytest.raises(ConfigError, match="loop_slice_ms"):
        parse_config({"lifecycle": {"loop_slice_ms": slice_ms}})
