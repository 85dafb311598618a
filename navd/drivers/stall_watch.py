"""The stall watch: a small process beside the daemon that stops the wheels when the daemon
cannot.

The chassis driver writes a wheel line every period from the event loop. If the loop stalls
(a handler stuck in C code that holds the GIL, a swapped-out process, a SIGSTOP) or the
daemon dies (SIGKILL, an out-of-memory kill), the STM32 keeps executing the last line it was
given. A thread in the daemon cannot help: it needs the GIL the stall may hold. So while the
port is open a separate process holds a duplicate of the port's descriptor and a shared
heartbeat (the monotonic time of the daemon's last line, and how many stops the watch
wrote):

- the daemon's last line older than the reaction timeout: the watch writes the stop line,
  once per period while it lasts;
- the daemon gone (its parent id changed): the watch writes the stop line and exits.

Each line is one ``write`` of a few bytes, which the kernel's terminal layer never mixes with
another writer's line. The watch runs this file as a script in an isolated interpreter
(standard library only: a few megabytes, started in tens of milliseconds) and is ended when
the daemon closes the port (it holds the port's lock with it).
"""

from __future__ import annotations

import mmap
import os
import signal
import struct
import subprocess
import sys
import time

__all__ = ["StallWatch"]

_BEAT = struct.Struct("=d")  # [s, CLOCK_MONOTONIC] the daemon's last line, at offset 0
_STOPS = struct.Struct("=Q")  # stop lines the watch wrote, at offset 8
_SIZE = 16
CHECK_FRACTION = 0.25  # the watch looks every this fraction of the timeout (at most a period)


class StallWatch:
    """The daemon's side: starts the watch on an open port, beats, reads its stop count.

    Args:
        port_fd: the open port's descriptor (the watch gets a duplicate).
        timeout_s: [s] a daemon silent this long is stalled (the reaction timeout).
        period_s: [s] the stop line is repeated this often while the stall lasts.
        stop_line: the bytes that stop the wheels ("0 0" and the line ending).
    """

    def __init__(self, port_fd: int, timeout_s: float, period_s: float, stop_line: bytes) -> None:
        self._mem_fd = os.memfd_create("navd-stall-watch")
        os.ftruncate(self._mem_fd, _SIZE)
        self._mem = mmap.mmap(self._mem_fd, _SIZE)
        self.beat()
        check_s = min(period_s, CHECK_FRACTION * timeout_s)
        args = [str(port_fd), str(self._mem_fd), repr(timeout_s), repr(period_s), repr(check_s)]
        self._process = subprocess.Popen(
            [sys.executable, "-I", "-S", __file__, *args, stop_line.hex(), str(os.getpid())],
            pass_fds=(port_fd, self._mem_fd),
            stdin=subprocess.DEVNULL,
            stdout=subprocess.DEVNULL,
        )

    def beat(self) -> None:
        """A line was written now."""
        _BEAT.pack_into(self._mem, 0, time.monotonic())

    @property
    def stops(self) -> int:
        """Stop lines the watch has written so far."""
        count: int = _STOPS.unpack_from(self._mem, 8)[0]
        return count

    @property
    def running(self) -> bool:
        return self._process.poll() is None

    def close(self) -> None:
        """End the watch (the port is being closed: the daemon writes its own last stop)."""
        if self._process.poll() is None:
            self._process.terminate()
            try:
                self._process.wait(1.0)
            except subprocess.TimeoutExpired:
                self._process.kill()
                self._process.wait()
        self._mem.close()
        os.close(self._mem_fd)


def _watch(argv: list[str]) -> None:
    """The watch process: ``PORT_FD MEM_FD TIMEOUT_S PERIOD_S CHECK_S STOP_HEX DAEMON_PID``."""
    port_fd, mem_fd = int(argv[0]), int(argv[1])
    timeout_s, period_s, check_s = float(argv[2]), float(argv[3]), float(argv[4])
    stop_line, daemon = bytes.fromhex(argv[5]), int(argv[6])
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # a terminal's Ctrl-C is the daemon's to handle
    mem = mmap.mmap(mem_fd, _SIZE)
    stops, last_stop = 0, -float("inf")

    def stop() -> None:
        nonlocal stops, last_stop
        try:
            os.write(port_fd, stop_line)
        except OSError:
            return  # the port is gone (unplugged): nothing to stop through it
        stops += 1
        last_stop = time.monotonic()
        _STOPS.pack_into(mem, 8, stops)

    while True:
        time.sleep(check_s)
        if os.getppid() != daemon:  # the daemon died: its last line may be a moving one
            stop()
            return
        now = time.monotonic()
        if now - _BEAT.unpack_from(mem, 0)[0] > timeout_s and now - last_stop >= period_s:
            stop()


if __name__ == "__main__":
    _watch(sys.argv[1:])
