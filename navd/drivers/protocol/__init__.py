"""navd's wire protocol (version 1): the frames, their codec, and what they become.

- ``frames``: what clients send (hello, sensor data, control requests, clock steps);
- ``replies``: what navd answers (welcome, error, ack, status, goal progress, ...);
- ``codec``: one line of JSON to a typed frame and back, errors that name the field;
- ``convert``: sensor frames and control requests to bus messages.

docs/protocol.md is the specification a client author reads. No asyncio here.
"""

from navd.drivers.protocol.codec import (
    decode_clock,
    decode_control,
    decode_hello,
    decode_reply,
    decode_sensor,
    encode,
)
from navd.drivers.protocol.frames import PROTOCOL_VERSION

__all__ = [
    "PROTOCOL_VERSION",
    "decode_clock",
    "decode_control",
    "decode_hello",
    "decode_reply",
    "decode_sensor",
    "encode",
]
