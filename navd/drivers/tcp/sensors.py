"""The sensor role: lidar, IMU, GPS, compass, wheel odometry and beacon lines become bus messages.

The fast path of the server. The lines of one read are counted (a simulated clock waits for
them, see ``LineCounts``) and handled together: one arrival time, one staleness check, then each
line decoded, stamped on the daemon clock and published. A bad line is answered with an error
naming the field; the lines around it are used.
"""

from __future__ import annotations

import functools
import math

from navd.drivers.convert import sensor_message
from navd.drivers.tcp.session import Server, Session
from navd.geometry import SensorMounts, UnknownMountError
from navd.lifecycle.messages import DeviceKind, DeviceResumed
from navd.wire import PingFrame, PointsFrame, Pong, RangeFrame, WireError, decode_sensor

__all__ = ["SensorRole"]


class SensorRole:
    """Handles every sensor session of the server."""

    def __init__(self, server: Server) -> None:
        self._server = server
        self._lidar = ("", -math.inf)  # the lidar that spoke last, and when [s]

    def opened(self, session: Session) -> None:
        """Nothing to start: a sensor just streams."""

    def lines(self, session: Session, lines: list[bytes]) -> None:
        count = sum(1 for line in lines if line and not line.isspace())
        handle = functools.partial(self._handle, session, lines)
        self._server.ctx.line_counts.take(session.device_id, count, handle)

    def closed(self, session: Session) -> None:
        self._server.ctx.line_counts.add_received(session.device_id)  # the end counts as a line

    def _handle(self, session: Session, lines: list[bytes]) -> None:
        """Lines that arrived together (at once, or on simulated time at the next step, in
        device order)."""
        ctx = self._server.ctx
        now = ctx.clock.now()
        session.last_line_s = now
        fresh = False
        conn, role, device_id, stamps = (
            session.conn,
            session.kind.value,
            session.device_id,
            session.stamps,
        )
        publish = ctx.publish
        mounts = self._server.settings.value.mounts
        for line in lines:
            if not line or line.isspace():
                continue
            try:
                frame = decode_sensor(role, line)
                if isinstance(frame, PingFrame):
                    conn.send(Pong(id=frame.id))
                    continue
                # only ROS-shaped frames have one (a model's fields are in its __dict__;
                # getattr of a missing one costs pydantic an exception, at every IMU line)
                frame_id = vars(frame).get("frame_id")
                if frame_id is not None:
                    refusal = mounts.frame_refusal(device_id, frame_id)
                    if refusal is not None:
                        raise WireError("header.frame_id", refusal)
                if role == "lidar" and not mounts.lidars:
                    self._one_lidar(device_id, now)
                elif isinstance(frame, RangeFrame | PointsFrame):
                    _check_mount(frame, device_id, mounts)
                message = sensor_message(frame, device_id, stamps.to_daemon(frame.stamp, now), now)
            except Exception as err:
                self._server.reject(conn, line, err)
                continue
            if not fresh:  # data, not a ping, a blank line or a rejected frame: it speaks
                fresh = True
                self._heard(session, now)
            session.accepted += 1
            if message is not None:
                publish(message)

    def _one_lidar(self, device_id: str, now: float) -> None:
        """Without lidar mounts, the ``lidar`` section places one lidar: a scan of another
        while the first speaks is refused (two lidars connected before either spoke).

        Raises:
            WireError: another lidar sent a scan within its staleness timeout.
        """
        speaking, last_s = self._lidar
        if speaking not in ("", device_id) and now - last_s < self._lidar_timeout_s():
            raise WireError(
                "device_id",
                f"{device_id!r} is a second lidar beside {speaking!r}: give each lidar its "
                "mount under [mounts.lidars] in the config",
            )
        self._lidar = (device_id, now)

    def _lidar_timeout_s(self) -> float:
        timeouts = dict(self._server.settings.value.stale_after_s)
        return timeouts[DeviceKind.LIDAR]

    def _heard(self, session: Session, now: float) -> None:
        """The sensor sent data at ``now`` [s]: it is fresh again if it was stale."""
        session.heard(now)
        if session.stale:
            session.stale = False
            self._server.ctx.publish(
                DeviceResumed(
                    stamp=now, received=now, device_id=session.device_id, kind=session.kind
                )
            )


def _check_mount(frame: RangeFrame | PointsFrame, device_id: str, mounts: SensorMounts) -> None:
    """A range sensor's or a depth camera's reading needs its mount: a cone or a cloud
    that points nowhere cannot be placed.

    Raises:
        WireError: on ``sensor``, naming the mount to add.
    """
    name = frame.sensor or device_id
    try:
        if isinstance(frame, RangeFrame):
            mounts.body.range_sensor(name)
        else:
            mounts.body.depth_camera(name)
    except UnknownMountError as err:
        raise WireError("sensor", str(err)) from None
