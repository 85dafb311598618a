"""A synthetic sensor program for benchmarks: streams one kind of frame at a fixed rate.

Run as ``python -m navd.bench.sensor_client --role imu --rate 1000 --seconds 10 --port P``.
It connects, prints ``{"ready": true}``, and starts streaming when a line arrives on its
standard input, so several clients start together after their start-up. When done it waits
until navd has processed everything (ping/pong), prints ``{"sent": N}`` and then holds the
connection open until its standard input closes, so the caller can read the daemon's
counters while the device is still listed.
"""

from __future__ import annotations

import argparse
import base64
import json
import math
import sys
import time

from navd.bench.synthetic_room import cast
from navd.geometry import Pose2
from navd.wire import (
    Client,
    FixFrame,
    HeadingFrame,
    ImuFrame,
    PingFrame,
    Pong,
    ScanFrame,
    SensorFrame,
    encode,
    frame_text,
)


def frame(role: str, rays: int, binary: bool) -> SensorFrame:
    """A representative frame for ``role`` (the stamp is filled in when sent)."""
    if role == "imu":
        return ImuFrame(
            stamp=None,
            angular_velocity=(0.001, -0.002, 0.05),
            linear_acceleration=(0.12, -0.03, 9.807),
        )
    if role == "gps":
        return FixFrame(
            stamp=None,
            latitude=52.520008,
            longitude=13.404954,
            altitude=34.0,
            horizontal_accuracy=1.5,
        )
    if role == "compass":
        return HeadingFrame(stamp=None, bearing_deg=123.4, accuracy_deg=2.0)
    if role == "lidar":
        # A robot standing in the synthetic room: what a real lidar indoors sees (random
        # ranges would make every scan a hard, unrepresentative case for the matcher).
        angle_min, increment, exact = cast(Pose2(-3.0, -1.0, 0.3), beams=rays)
        ranges = exact.astype("<f4")
        if binary:
            return ScanFrame(
                stamp=None,
                angle_min=angle_min,
                angle_increment=increment,
                range_min=0.1,
                range_max=12.0,
                ranges_f32=base64.b64encode(ranges.tobytes()).decode(),
            )
        return ScanFrame(  # no return: null
            stamp=None,
            angle_min=angle_min,
            angle_increment=increment,
            range_min=0.1,
            range_max=12.0,
            ranges=[round(float(r), 3) if math.isfinite(r) else None for r in ranges],
        )
    raise SystemExit(f"unknown role {role!r}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--role", required=True)
    parser.add_argument("--rate", type=float, required=True, help="[Hz]")
    parser.add_argument("--seconds", type=float, required=True)
    parser.add_argument("--port", type=int, required=True)
    parser.add_argument("--rays", type=int, default=1440)
    parser.add_argument("--binary", action="store_true", help="lidar ranges as base64 float32")
    parser.add_argument(
        "--batch",
        type=int,
        default=1,
        help="frames written per send (a sensor reading a FIFO in bursts)",
    )
    args = parser.parse_args()
    client = Client(
        "127.0.0.1", args.port, role=args.role, device_id=f"bench-{args.role}", timeout_s=None
    )
    sample = frame(args.role, args.rays, args.binary)
    print(json.dumps({"ready": True}), flush=True)
    sys.stdin.readline()  # start together with the other clients
    period = 1.0 / args.rate
    start = time.monotonic()
    sent = 0
    while (now := time.monotonic()) - start < args.seconds:
        # stamps are the sender's own clock, one sample period apart, as a sensor stamps them
        burst = b"".join(
            encode(sample.model_copy(update={"stamp": now - (args.batch - 1 - i) * period}))
            for i in range(args.batch)
        )
        client.send_raw(burst)
        sent += args.batch
        time.sleep(max(0.0, start + sent * period - time.monotonic()))
    client.send(PingFrame(id="end"))
    while True:
        reply = client.receive()
        if isinstance(reply, Pong):
            break
        print(f"unexpected reply: {frame_text(reply)}", file=sys.stderr)
    print(json.dumps({"sent": sent}), flush=True)
    sys.stdin.read()
    client.close()


if __name__ == "__main__":
    main()
