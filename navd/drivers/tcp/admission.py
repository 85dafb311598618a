"""Admission: whether a hello may open a session (the token, the connection caps, ids held
by other connections, mounts, the clock client's rules), and the reason given when not."""

from __future__ import annotations

import hmac
from collections.abc import Mapping

from navd.drivers.tcp.clock import ClockRole
from navd.drivers.tcp.session import Session
from navd.drivers.tcp.settings import TcpSettings
from navd.lifecycle.messages import DeviceKind
from navd.wire import Hello

__all__ = ["admission_refusal"]


def admission_refusal(
    hello: Hello, sessions: Mapping[str, Session], settings: TcpSettings, clock_role: ClockRole
) -> tuple[str, str] | None:
    """(field, reason) if the hello may not open a session, None if it may: the token, the
    server's and the control clients' caps, an id held by another connection, the mounts,
    and the clock client's own rules."""
    token = settings.token
    if token is not None and not hmac.compare_digest((hello.token or "").encode(), token.encode()):
        return "token", "missing or wrong token"
    holder = sessions.get(hello.device_id)
    limit = settings.max_clients
    if holder is None and len(sessions) >= limit:
        return "", f"server full: {limit} clients connected (tcp.max_clients)"
    controls = settings.max_control_clients
    if (
        holder is None
        and hello.role == "control"
        and sum(1 for x in sessions.values() if x.kind is DeviceKind.CONTROL) >= controls
    ):
        return "", (
            f"control clients full: {controls} connected (tcp.max_control_clients; the "
            "rest of tcp.max_clients is kept for sensors)"
        )
    if holder is not None and holder.kind.value != hello.role:
        return "device_id", (
            f"{hello.device_id!r} is the id of a {holder.kind.value} connected from "
            f"{holder.conn.peer}; a {hello.role} needs an id of its own"
        )
    if holder is not None and not holder.stale and holder.kind is not DeviceKind.CONTROL:
        return "device_id", (
            f"{hello.device_id!r} is in use by {holder.conn.peer} (a {holder.kind.value}); "
            "a sensor's id stays with its connection until it leaves or falls silent"
        )
    mounts = settings.mounts
    unmounted = mounts.refusal(hello.role, hello.device_id)
    if unmounted is not None:
        return "device_id", unmounted
    if hello.role == "lidar" and not mounts.lidars:
        # One implicit mount (the lidar section) cannot place two lidars.
        for other in sessions.values():
            if (
                other.kind is DeviceKind.LIDAR
                and other.device_id != hello.device_id
                and other.accepted > 0  # a lidar that is speaking, not just connected
                and not other.stale
            ):
                return "device_id", (
                    f"{hello.device_id!r} would be a second lidar beside "
                    f"{other.device_id!r}: give each lidar its mount under "
                    "[mounts.lidars] in the config"
                )
    if hello.role == "clock":
        refusal = clock_role.refusal(hello.device_id, sessions.values())
        if refusal:
            return "role", refusal
    return None
