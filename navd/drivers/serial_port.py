"""Opening a serial port for one program only.

Two programs on one UART each see part of what the device sends, and two drivers on the
chassis's UART both command the wheels. navd therefore takes an advisory lock on every port
it opens (``flock``, as pyserial's ``exclusive`` does, and as minicom, ModemManager and other
careful programs do), and a port already locked is refused with the reason, where opening it
anyway would have split its bytes silently.
"""

from __future__ import annotations

import errno
from typing import Any

import serial

__all__ = ["PortInUseError", "open_exclusive"]

_LOCK_HELD = (errno.EAGAIN, errno.EWOULDBLOCK, errno.EACCES)


class PortInUseError(serial.SerialException):  # type: ignore[misc]  # pyserial is untyped
    """Another program holds the port's lock."""


def open_exclusive(port: str, baudrate: int, **options: Any) -> serial.Serial:
    """Open ``port`` at ``baudrate`` [baud] with pyserial, locked against other programs.

    Raises:
        PortInUseError: another program (another navd, a terminal program) has it open and
            locked.
        serial.SerialException, OSError, ValueError: as ``serial.Serial`` raises them (no such
            port, no permission, an unsupported speed).
    """
    try:
        return serial.Serial(port=port, baudrate=baudrate, exclusive=True, **options)
    except serial.SerialException as err:
        if err.errno in _LOCK_HELD:
            raise PortInUseError(
                err.errno,
                f"{port} is in use by another program (another navd or sensor program, a "
                "terminal such as minicom or screen); stop it, or give this one another port",
            ) from err
        raise
