"""A viewer of the live view for the ingest benchmark, in its own process: connects as the
Foxglove app does, subscribes to every channel, reads every message without decoding it, and
prints how many came per topic when its standard input closes.

Needs the ``websockets`` package (a development dependency).
"""

from __future__ import annotations

import argparse
import asyncio
import json
import struct
import sys

from websockets.asyncio.client import connect

SUBPROTOCOL = "foxglove.sdk.v1"
MESSAGE_DATA = 0x01


async def _view(port: int) -> dict[str, int]:
    counts: dict[str, int] = {}
    topics: dict[int, str] = {}  # subscription id -> topic
    done = asyncio.get_running_loop().run_in_executor(None, sys.stdin.read)
    async with connect(f"ws://127.0.0.1:{port}", subprotocols=[SUBPROTOCOL]) as ws:  # type: ignore[list-item]
        print(json.dumps({"connected": True}), flush=True)
        while not done.done():
            try:
                frame = await asyncio.wait_for(ws.recv(), 0.2)
            except TimeoutError:
                continue
            if isinstance(frame, str):
                op = json.loads(frame)
                if op.get("op") == "advertise":
                    subscriptions = []
                    for channel in op["channels"]:
                        sub_id = len(topics) + 1
                        topics[sub_id] = channel["topic"]
                        subscriptions.append({"id": sub_id, "channelId": channel["id"]})
                    await ws.send(json.dumps({"op": "subscribe", "subscriptions": subscriptions}))
            elif frame[0] == MESSAGE_DATA:
                topic = topics.get(struct.unpack_from("<I", frame, 1)[0], "?")
                counts[topic] = counts.get(topic, 0) + 1
    return counts


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--port", type=int, required=True)
    args = parser.parse_args()
    print(json.dumps({"received": asyncio.run(_view(args.port))}), flush=True)


if __name__ == "__main__":
    main()
