"""A device's end of a serial line: a pseudo-terminal whose other end a program opens as it
would /dev/ttyUSB0, and the pace at which a UART shifts bytes onto it.

A UART sends 10 bits a byte (8N1): at 230400 baud a byte takes 43 µs, a 47-byte LD06 packet
2 ms. A USB serial adapter forwards what it has received in frames about a millisecond
apart. So bytes reach the host in small chunks spread over the time the line needs, never a
whole turn at once; ``UartWriter`` writes them that way. A device nobody reads loses what it
sends (the pseudo-terminal's buffer full): the bytes are dropped and counted, as a real line
drops them.
"""

from __future__ import annotations

import contextlib
import errno
import fcntl
import os
import time
import tty
from collections.abc import Callable
from pathlib import Path

__all__ = ["USB_FRAME_S", "SerialLine", "UartWriter"]

USB_FRAME_S = 0.001  # [s] a USB full-speed adapter forwards what it received every frame
BITS_PER_BYTE = 10  # start bit, 8 data bits, stop bit


class SerialLine:
    """A pseudo-terminal in raw mode: ``fd`` is the device's end, ``path`` the host's (or
    ``link``, a symlink to it, when one is given).

    Args:
        link: where a symlink to the host's end goes (a stable name such as /dev/lidar0).
    """

    def __init__(self, link: Path | None = None) -> None:
        self.fd, self._host = os.openpty()
        tty.setraw(self._host)  # bytes pass unchanged, nothing echoed back to the device
        flags = fcntl.fcntl(self.fd, fcntl.F_GETFL)
        fcntl.fcntl(self.fd, fcntl.F_SETFL, flags | os.O_NONBLOCK)
        self.path = Path(os.ttyname(self._host))
        self.link = link
        if link is not None:
            with contextlib.suppress(FileNotFoundError):
                link.unlink()
            link.symlink_to(self.path)

    @property
    def name(self) -> str:
        """What a program opens: the link if there is one, else the terminal itself."""
        return str(self.link or self.path)

    def read_available(self) -> bytes:
        """What the host wrote and the device has not read yet (b"" when nothing)."""
        try:
            return os.read(self.fd, 4096)
        except BlockingIOError:
            return b""
        except OSError as err:
            if err.errno == errno.EIO:  # the host's end is not open (yet)
                return b""
            raise

    def close(self) -> None:
        """Close both ends and the link."""
        if self.link is not None:
            with contextlib.suppress(FileNotFoundError):
                self.link.unlink()
        for fd in (self.fd, self._host):
            with contextlib.suppress(OSError):
                os.close(fd)


class UartWriter:
    """Writes bytes onto a line as a UART at ``baud`` shifts them out, forwarded in
    ``frame_s`` chunks.

    Args:
        fd: the device's end (non-blocking).
        baud: the line's rate [bit/s].
        frame_s: [s] how often the adapter forwards what it received.
        clock, sleep: time.monotonic and time.sleep (tests give their own).

    Attributes:
        dropped_bytes: bytes the host's end had no room for.
        free_at: [s] when the line has shifted out everything written so far.
    """

    def __init__(
        self,
        fd: int,
        baud: int,
        frame_s: float = USB_FRAME_S,
        clock: Callable[[], float] = time.monotonic,
        sleep: Callable[[float], None] = time.sleep,
    ) -> None:
        self.fd = fd
        self.byte_s = BITS_PER_BYTE / baud
        self.frame_s = frame_s
        self.clock = clock
        self.sleep = sleep
        self.dropped_bytes = 0
        self.free_at = 0.0

    def send(self, data: bytes, ready_s: float) -> float:
        """Shift ``data`` out from ``ready_s`` [s, monotonic] (or once the line is free),
        returning when its last byte has been forwarded; [s] when that byte left the UART."""
        start = max(ready_s, self.free_at)
        end = start + len(data) * self.byte_s
        self.free_at = end
        sent = 0
        while sent < len(data):
            now = self.clock()
            done = min(len(data), int((now - start) / self.byte_s))
            if done > sent:
                self._write(data[sent:done])
                sent = done
            if sent < len(data):
                next_byte = start + (sent + 1) * self.byte_s
                self.sleep(max(next_byte - now, self.frame_s))
        return end

    def _write(self, chunk: bytes) -> None:
        try:
            written = os.write(self.fd, chunk)
        except BlockingIOError:
            written = 0
        except OSError as err:
            if err.errno != errno.EIO:  # EIO: the host's end is closed; the bytes are lost
                raise
            written = 0
        self.dropped_bytes += len(chunk) - written
