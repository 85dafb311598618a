"""numba's kernel cache filled by a child process: which kernels count, when the child runs,
and what happens when it fails or the daemon stops meanwhile."""

from __future__ import annotations

import importlib
import io
import pkgutil
import sys
import threading
import time
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import Any

import pytest
from numba.core.dispatcher import Dispatcher

import navd
from navd import kernels
from navd.kernels import KERNEL_MODULES, KernelCache, KernelCacheError
from navd.logs import add_log_tap, configure_logging, remove_log_tap

# Not the daemon's: the simulator's own kernels and the benchmarks'.
OUTSIDE_THE_DAEMON = ("navd.sim", "navd.bench")


@pytest.fixture
def events() -> Iterator[list[Mapping[str, Any]]]:
    configure_logging("info", "json", stream=io.StringIO())
    seen: list[Mapping[str, Any]] = []
    add_log_tap(seen.append)
    yield seen
    remove_log_tap(seen.append)


def _python(code: str) -> tuple[str, ...]:
    return (sys.executable, "-c", code)


def test_every_module_of_the_daemon_that_defines_a_kernel_is_listed() -> None:
    defining = set()
    for info in pkgutil.walk_packages(navd.__path__, "navd."):
        if info.name.startswith(OUTSIDE_THE_DAEMON) or info.name == "navd.__main__":
            continue
        module = importlib.import_module(info.name)
        for value in vars(module).values():
            if isinstance(value, Dispatcher) and value.py_func.__module__ == info.name:
                defining.add(info.name)
    assert defining == set(KERNEL_MODULES)


def test_every_kernel_of_the_daemon_lets_the_event_loop_run_meanwhile() -> None:
    # A kernel that kept the interpreter lock would stall the event loop for as long as it
    # runs in a worker (as kiss-icp's C++ did, up to 6 ms at a time).
    holding = [
        name
        for name, dispatcher in kernels._dispatchers()
        if not dispatcher.targetoptions.get("nogil")
    ]
    assert holding == []


def test_a_warm_cache_starts_no_child(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    marker = tmp_path / "ran"
    monkeypatch.setattr(kernels, "cold_kernels", list)
    cache = KernelCache(_python(f"open({str(marker)!r}, 'w')"))
    cache.prepare()
    assert not marker.exists()


def test_a_cold_cache_is_filled_once_for_all_warm_ups(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path, events: list[Mapping[str, Any]]
) -> None:
    runs = tmp_path / "runs"
    monkeypatch.setattr(kernels, "cold_kernels", lambda: ["navd.planning._guard_kernels.sweep"])
    # Each run appends a line; a slow child, so the four warm-ups all wait for the same one.
    cache = KernelCache(
        _python(f"import time; time.sleep(0.3); open({str(runs)!r}, 'a').write('x\\n')")
    )
    threads = [threading.Thread(target=cache.prepare) for _ in range(4)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join(timeout=30.0)
    assert runs.read_text() == "x\n"
    assert [e["event"] for e in events] == ["kernels_compiling", "kernels_compiled"]
    cache.prepare()
    assert runs.read_text() == "x\n"


def test_a_failing_child_is_logged_and_the_warm_ups_go_on(
    monkeypatch: pytest.MonkeyPatch, events: list[Mapping[str, Any]]
) -> None:
    monkeypatch.setattr(kernels, "cold_kernels", lambda: ["navd.planning._guard_kernels.sweep"])
    cache = KernelCache(_python("import sys; print('no space left'); sys.exit(3)"))
    cache.prepare()  # never raises: the warm-ups then compile in the daemon
    failed = [e for e in events if e["event"] == "kernels_compile_failed"]
    assert len(failed) == 1
    assert failed[0]["reason"] == "exit code 3"
    assert "no space left" in failed[0]["output"]
    missing = KernelCache(("/nonexistent/python",))
    missing.prepare()
    assert sum(e["event"] == "kernels_compile_failed" for e in events) == 2


def test_stopping_ends_a_compile_still_running(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path, events: list[Mapping[str, Any]]
) -> None:
    started = tmp_path / "started"
    monkeypatch.setattr(kernels, "cold_kernels", lambda: ["navd.planning._guard_kernels.sweep"])
    cache = KernelCache(
        _python(f"import time; open({str(started)!r}, 'w').close(); time.sleep(600)")
    )
    thread = threading.Thread(target=cache.prepare)
    thread.start()
    deadline = time.monotonic() + 60.0
    while not started.exists() and time.monotonic() < deadline:
        time.sleep(0.01)
    assert started.exists()
    cache.stop()
    thread.join(timeout=60.0)  # the compile would take ten minutes
    assert not thread.is_alive()
    assert [e["event"] for e in events] == ["kernels_compiling"]  # neither done nor failed
    cache.prepare()  # done: nothing starts again


def test_a_cache_navd_cannot_read_is_said_and_nothing_is_started(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path, events: list[Mapping[str, Any]]
) -> None:
    marker = tmp_path / "ran"

    def unreadable() -> list[str]:
        raise KernelCacheError("numba 9.9 keeps its cache in a way navd cannot read")

    monkeypatch.setattr(kernels, "cold_kernels", unreadable)
    KernelCache(_python(f"open({str(marker)!r}, 'w')")).prepare()
    assert not marker.exists()
    (said,) = [e for e in events if e["event"] == "kernels_cache_unreadable"]
    assert "numba 9.9" in said["reason"]

    def broken() -> list[str]:
        raise RuntimeError("an index file cut short")

    monkeypatch.setattr(kernels, "cold_kernels", broken)
    KernelCache(_python(f"open({str(marker)!r}, 'w')")).prepare()  # never raises
    (failed,) = [e for e in events if e["event"] == "kernels_prepare_failed"]
    assert failed["error"] == "an index file cut short"
    assert not marker.exists()
