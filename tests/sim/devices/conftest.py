"""Device emulators on real pseudo-terminals, streaming in a thread for the test's length."""

from __future__ import annotations

import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager

import pytest
import serial.serialposix

from navd.sim.devices import SerialLine


@contextmanager
def streaming(serve: Callable[[SerialLine, threading.Event], None]) -> Iterator[SerialLine]:
    """A serial line with a device serving it until the block ends."""
    line = SerialLine()
    stop = threading.Event()
    thread = threading.Thread(target=serve, args=(line, stop), daemon=True)
    thread.start()
    try:
        yield line
    finally:
        stop.set()
        thread.join(5.0)
        line.close()


@pytest.fixture
def no_modem_lines(monkeypatch: pytest.MonkeyPatch) -> None:
    """A pseudo-terminal has no DTR line, which host drivers set to start an A1's motor:
    setting it does nothing here (the emulated motor always runs)."""
    monkeypatch.setattr(serial.serialposix.Serial, "_update_dtr_state", lambda self: None)
