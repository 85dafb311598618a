"""systemd's notify protocol (sd_notify), spoken directly: one datagram per state change.

Under ``Type=notify`` systemd passes ``NOTIFY_SOCKET`` (a unix datagram socket; a leading
``@`` means the abstract namespace) and, with ``WatchdogSec=``, ``WATCHDOG_USEC``. navd sends
``READY=1`` once its modules are active, ``WATCHDOG=1`` from its event loop at half the
watchdog period (a stalled loop stops the pings and systemd restarts navd), ``STATUS=`` lines,
``RELOADING=1`` around a SIGHUP reload and ``STOPPING=1`` when it begins to shut down.
Without ``NOTIFY_SOCKET`` every call does nothing. The protocol is a few lines, so no
library is needed.
"""

from __future__ import annotations

import os
import socket
from collections.abc import Mapping

from navd.logs import get_logger

__all__ = ["SystemdNotifier"]

_log = get_logger("lifecycle.sdnotify")


class SystemdNotifier:
    """Sends notifications to systemd if it asked for them.

    Args:
        environ: the process environment (injectable for tests).
    """

    def __init__(self, environ: Mapping[str, str] | None = None) -> None:
        env = os.environ if environ is None else environ
        address = env.get("NOTIFY_SOCKET", "")
        self._address = "\0" + address[1:] if address.startswith("@") else address
        self._socket: socket.socket | None = None
        if self._address:
            self._socket = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM | socket.SOCK_CLOEXEC)
            self._socket.setblocking(False)
        self.watchdog_period_s = _watchdog_period(env)

    @property
    def enabled(self) -> bool:
        """True when systemd passed a notify socket."""
        return self._socket is not None

    def notify(self, *lines: str) -> bool:
        """Send ``KEY=value`` lines in one datagram; False if not sent (logged once)."""
        if self._socket is None:
            return False
        try:
            self._socket.sendto("\n".join(lines).encode(), self._address)
        except OSError as err:
            _log.warning("sd_notify_failed", error=str(err), lines=list(lines))
            return False
        return True

    def close(self) -> None:
        if self._socket is not None:
            self._socket.close()
            self._socket = None


def _watchdog_period(env: Mapping[str, str]) -> float | None:
    """[s] the watchdog timeout systemd expects pings within, or None without a watchdog."""
    usec = env.get("WATCHDOG_USEC")
    if not usec:
        return None
    pid = env.get("WATCHDOG_PID")
    if pid and pid != str(os.getpid()):
        return None  # meant for another process
    try:
        period = int(usec) / 1e6
    except ValueError:
        _log.warning("watchdog_usec_invalid", value=usec)
        return None
    return period if period > 0 else None
