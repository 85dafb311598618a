"""Opening a serial port for one program only.

Two programs on one UART each see part of what the device sends, and two drivers on the
chassis's UART both command the wheels. navd therefore takes an advisory lock on every port
it opens (``flock``, through pyserial's ``exclusive``, before the port's settings are
touched), and a port another navd or another program that locks the same way (picocom, for
one) holds is refused with the reason, where opening it anyway would have split its bytes
silently. Programs that take no such lock (screen, or minicom with its lock files in
/var/lock) are not seen: ``fuser -v PORT`` names whoever has the port open.
"""

from __future__ import annotations

import errno
from typing import Any

import serial

__all__ = ["PortInUseError", "open_exclusive"]

# what flock says of a lock held elsewhere (not EACCES: that is a port without permission)
_LOCK_HELD = (errno.EAGAIN, errno.EWOULDBLOCK)


class PortInUseError(serial.SerialException):  # type: ignore[misc]  # pyserial is untyped
    """Another program holds the port's lock."""


def open_exclusive(port: str, baudrate: int, **options: Any) -> serial.Serial:
    """Open ``port`` at ``baudrate`` [baud] with pyserial, locked against other programs.

    Raises:
        PortInUseError: another program (another navd, picocom) has it open and locked.
        serial.SerialException, OSError, ValueError: as ``serial.Serial`` raises them (no such
            port, no permission, an unsupported speed).
    """
    try:
        return serial.Serial(port=port, baudrate=baudrate, exclusive=True, **options)
    except serial.SerialException as err:
        if err.errno in _LOCK_HELD:
            raise PortInUseError(
                err.errno,
                f"{port} is in use by another program (another navd or sensor program, or a "
                f"terminal such as picocom; `fuser -v {port}` names it): stop it, or give "
                "this one another port",
            ) from err
        raise
