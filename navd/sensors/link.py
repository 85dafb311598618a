"""Where a sensor program reads and where it sends, as its command line gives it."""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["Link"]


@dataclass(frozen=True, slots=True)
class Link:
    """Where a sensor program reads and where it sends.

    Attributes:
        port, baud: the device's serial port and rate.
        host, navd_port: where navd listens.
        device_id: the name navd knows the device by.
        token: navd's ``tcp.token``, when it has one.
        scan_mode: an RPLIDAR's scan mode by name (None: the lidar's own choice).
        range_max_m: [m] overrides the longest range the device reports.
    """

    port: str
    baud: int
    host: str
    navd_port: int
    device_id: str
    token: str | None = None
    scan_mode: str | None = None
    range_max_m: float | None = None
