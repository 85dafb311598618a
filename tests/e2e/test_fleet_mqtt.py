"""navd as a VDA 5050 vehicle on a real mosquitto, driving the simulated office (lockstep): a
fleet control's order is driven node by node and reported; refused orders and instant
actions come back as errors in the state; the broker killed mid-drive holds the robot and,
restarted, lets the order go on without driving it twice; a vehicle that dies leaves its
last will, CONNECTIONBROKEN. Every message navd sends validates against the 2.1.0 schemas."""

from __future__ import annotations

import asyncio
import contextlib
import functools
import itertools
import json
import math
import shutil
import signal
import subprocess
from collections.abc import AsyncIterator, Callable
from pathlib import Path
from typing import Any

import pytest

from navd.sim import Session, from_shapes, office, session
from navd.wire import GoalFrame, GoalStatusFrame, InitialPoseFrame
from tests.fleet.broker import Broker
from tests.fleet.mqtt311_gate import Mqtt311Gate
from tests.fleet.vda5050_schemas import check

aiomqtt = pytest.importorskip("aiomqtt", reason="aiomqtt missing")
pytestmark = pytest.mark.e2e

SERIAL = "robot-1"
PREFIX = f"uagv/v2/navd/{SERIAL}"
# From the start room through its door to the corridor, then along it.
ROUTE = [("start", 0.0, 0.0), ("door", 3.5, 3.2), ("corridor", 8.5, 3.2)]


class FleetSide:
    """The fleet control's end of the broker: everything the vehicle says, checked against
    its schema as it comes, and orders and instant actions sent to it."""

    def __init__(self, client: Any) -> None:
        self.client = client
        self.heard: list[tuple[str, dict[str, Any]]] = []
        self.headers = 0

    async def listen(self) -> None:
        async for message in self.client.messages:
            topic = str(message.topic).rsplit("/", 1)[-1]
            body = json.loads(message.payload)
            if topic in ("order", "instantActions"):
                continue  # our own
            check(topic, body)
            self.heard.append((topic, body))

    def last(self, topic: str) -> dict[str, Any] | None:
        return next((b for t, b in reversed(self.heard) if t == topic), None)

    async def until(
        self, topic: str, predicate: Callable[[dict[str, Any]], bool], s: Session, limit_s: float
    ) -> dict[str, Any]:
        """The first message on ``topic`` (from now on, or already heard) that satisfies
        ``predicate``, within ``limit_s`` of simulated time."""
        deadline = s.sim.now() + limit_s
        seen = 0
        while s.sim.now() < deadline:
            s.check()
            for t, body in self.heard[seen:]:
                if t == topic and predicate(body):
                    return body
            seen = len(self.heard)
            await asyncio.sleep(0.05)
        raise AssertionError(f"no {topic} as wanted within {limit_s} s; last: {self.last(topic)}")

    def _head(self) -> dict[str, Any]:
        self.headers += 1
        return {
            "headerId": self.headers,
            "timestamp": "2026-12-02T08:00:00.00Z",
            "version": "2.1.0",
            "manufacturer": "navd",
            "serialNumber": SERIAL,
        }

    async def order(
        self, order_id: str, update: int, nodes: list[tuple[str, float, float]], first_seq: int = 0
    ) -> dict[str, Any]:
        wire_nodes = [
            {
                "nodeId": name,
                "sequenceId": first_seq + 2 * i,
                "released": True,
                "nodePosition": {"x": x, "y": y, "mapId": "map", "allowedDeviationXY": 0.5},
                "actions": [],
            }
            for i, (name, x, y) in enumerate(nodes)
        ]
        edges = [
            {
                "edgeId": f"{a['nodeId']}-{b['nodeId']}",
                "sequenceId": a["sequenceId"] + 1,
                "released": True,
                "startNodeId": a["nodeId"],
                "endNodeId": b["nodeId"],
                "actions": [],
            }
            for a, b in itertools.pairwise(wire_nodes)
        ]
        message = {
            **self._head(),
            "orderId": order_id,
            "orderUpdateId": update,
            "nodes": wire_nodes,
            "edges": edges,
        }
        check("order", message)
        await self.client.publish(f"{PREFIX}/order", json.dumps(message), qos=1)
        return message

    async def instant(self, *actions: dict[str, Any]) -> None:
        message = {**self._head(), "actions": list(actions)}
        check("instantActions", message)
        await self.client.publish(f"{PREFIX}/instantActions", json.dumps(message), qos=1)


@contextlib.asynccontextmanager
async def fleet_side(broker: Broker) -> AsyncIterator[FleetSide]:
    async with aiomqtt.Client("127.0.0.1", broker.port, identifier="test-fleet") as client:
        await client.subscribe(f"{PREFIX}/#", qos=1)
        side = FleetSide(client)
        task = asyncio.create_task(side.listen())
        try:
            yield side
        finally:
            task.cancel()
            with contextlib.suppress(asyncio.CancelledError, aiomqtt.MqttError):
                await task


def _vehicle(broker: Broker, **fleet: Any) -> dict[str, Any]:
    return {
        "fleet": {
            "enabled": True,
            "broker_url": broker.url,
            "serial_number": SERIAL,
            "visualization_rate_hz": 2.0,
            **fleet,
        }
    }


def _done(last_node: str) -> Callable[[dict[str, Any]], bool]:
    return lambda state: state["lastNodeId"] == last_node and not state["nodeStates"]


async def test_an_order_is_driven_and_reported_and_bad_ones_are_refused(tmp_path: Path) -> None:
    broker = Broker(tmp_path)
    broker.start()
    try:
        async with session(
            office(), tmp_path, overrides=_vehicle(broker), lockstep=True, hold_clock=True
        ) as s, fleet_side(broker) as fleet:  # fmt: skip
            s.control.send(InitialPoseFrame(x=0.0, y=0.0, yaw=0.0, std_xy=0.02))
            s.sim.release_clock()
            await fleet.until("connection", lambda m: m["connectionState"] == "ONLINE", s, 30.0)
            sheet = await fleet.until("factsheet", lambda m: True, s, 30.0)
            assert sheet["typeSpecification"]["agvKinematic"] == "DIFF"
            await fleet.until("state", lambda m: "agvPosition" in m, s, 30.0)
            await fleet.order("o1", 0, ROUTE)
            moving = await fleet.until("state", lambda m: m["driving"], s, 30.0)
            assert moving["orderId"] == "o1" and moving["lastNodeId"] == "start"
            done = await fleet.until("state", _done("corridor"), s, 240.0)
            assert done["errors"] == [] and done["lastNodeSequenceId"] == 4
            position = done["agvPosition"]
            assert abs(position["x"] - 8.5) < 0.5 and abs(position["y"] - 3.2) < 0.5
            assert fleet.last("visualization") is not None
            # an update that does not start where the last one ended: refused by name
            await fleet.order("o1", 1, [("door", 3.5, 3.2), ("back", 1.0, 1.0)], first_seq=2)
            state = await fleet.until(
                "state",
                lambda m: any(e["errorType"] == "orderUpdateError" for e in m["errors"]),
                s,
                30.0,
            )
            assert state["lastNodeId"] == "corridor" and state["nodeStates"] == []
            # a new order whose first node is not where the robot stands: refused
            refused = await fleet.order("o2", 0, [("far", 0.0, 6.0), ("x", 1.0, 6.0)])
            state = await fleet.until(
                "state", lambda m: any(e["errorType"] == "orderError" for e in m["errors"]), s, 30.0
            )
            error = next(e for e in state["errors"] if e["errorType"] == "orderError")
            assert "the first node far is" in error["errorDescription"]
            assert {"referenceKey": "orderId", "referenceValue": refused["orderId"]} in error[
                "errorReferences"
            ]
            await fleet.instant(
                {"actionType": "liftFork", "actionId": "a1", "blockingType": "HARD"},
                {"actionType": "cancelOrder", "actionId": "a2", "blockingType": "HARD"},
            )
            state = await fleet.until(
                "state", lambda m: any(a["actionId"] == "a2" for a in m["actionStates"]), s, 30.0
            )
            statuses = {a["actionId"]: a["actionStatus"] for a in state["actionStates"]}
            assert statuses["a1"] == "FAILED" and statuses["a2"] == "FAILED"  # no order to cancel
            kinds = {e["errorType"] for e in state["errors"]}
            assert {"unsupportedAction", "noOrderToCancel"} <= kinds
            assert s.sim.body.collisions == 0
    finally:
        broker.stop()


async def test_a_lost_broker_holds_the_robot_and_the_order_goes_on_once_it_is_back(
    tmp_path: Path,
) -> None:
    broker = Broker(tmp_path)
    broker.start()
    try:
        async with session(
            office(), tmp_path, overrides=_vehicle(broker, keepalive_s=2), lockstep=True,
            hold_clock=True,
        ) as s:  # fmt: skip
            s.control.send(InitialPoseFrame(x=0.0, y=0.0, yaw=0.0, std_xy=0.02))
            s.sim.release_clock()
            async with fleet_side(broker) as fleet:
                await fleet.until("state", lambda m: "agvPosition" in m, s, 30.0)
                await fleet.order("o1", 0, ROUTE)
                await fleet.until("state", lambda m: m["driving"], s, 30.0)
            broker.kill()  # mid-drive, without a word to anyone
            killed_at = s.sim.now()
            while s.sim.now() < killed_at + 5.0:
                s.check()
                await asyncio.sleep(0.05)
            assert s.sim.body.linear_mps == 0.0  # held (fleet.on_broker_lost = "hold")
            held_at = (s.sim.body.x_m, s.sim.body.y_m)
            broker.start()
            async with fleet_side(broker) as fleet:
                await fleet.until("connection", lambda m: m["connectionState"] == "ONLINE", s, 60.0)
                await fleet.order("o1", 0, ROUTE)  # the fleet control sends it again: ignored
                done = await fleet.until("state", _done("corridor"), s, 240.0)
                assert done["orderUpdateId"] == 0 and done["errors"] == []
                assert (s.sim.body.x_m, s.sim.body.y_m) != held_at
        log = (tmp_path / "navd.log").read_text()
        # one goal to the corridor, through the door (nothing to do there; the goal is named
        # after the door, the first node on its way), and the same goal sent once more after
        # the hold cut it: the order sent again after the broker came back drove nothing twice
        goals = [
            entry["goal_id"]
            for entry in map(json.loads, log.splitlines())
            if entry.get("event") == "goal" and str(entry.get("goal_id", "")).startswith("vda:")
        ]
        legs = [goal_id.split(":")[2] for goal_id in goals]
        assert legs == ["2", "2"], goals
    finally:
        broker.stop()


async def test_a_vehicle_that_dies_leaves_connectionbroken_and_one_that_stops_offline(
    tmp_path: Path, daemon_on_port: Any
) -> None:
    broker = Broker(tmp_path)
    broker.start()
    try:
        fleet_toml = (
            f'[fleet]\nenabled = true\nbroker_url = "{broker.url}"\nserial_number = "{SERIAL}"\n'
            "keepalive_s = 2\n"
        )
        async with aiomqtt.Client("127.0.0.1", broker.port, identifier="watcher") as client:
            await client.subscribe(f"{PREFIX}/connection", qos=1)
            for how, said in ((signal.SIGKILL, "CONNECTIONBROKEN"), (signal.SIGTERM, "OFFLINE")):
                daemon, _ = daemon_on_port(fleet_toml)
                daemon.wait_for("fleet_connected", timeout_s=20.0)
                states = await _connection_states(client, until="ONLINE")
                assert states[-1] == "ONLINE"
                daemon.proc.send_signal(how)
                states = await _connection_states(client, until=said)
                assert states[-1] == said, states
                daemon.proc.wait(10)
    finally:
        broker.stop()


async def test_a_broker_of_mqtt_3_1_1_only_is_joined_in_3_1_1_and_said_so(
    tmp_path: Path, daemon_on_port: Any
) -> None:
    broker = Broker(tmp_path)
    broker.start()
    gate = Mqtt311Gate(broker.port)
    gate.start()
    try:
        fleet_toml = (
            f'[fleet]\nenabled = true\nbroker_url = "{gate.url}"\nserial_number = "{SERIAL}"\n'
        )
        async with aiomqtt.Client("127.0.0.1", broker.port, identifier="watcher") as client:
            await client.subscribe(f"{PREFIX}/connection", qos=1)
            daemon, _ = daemon_on_port(fleet_toml)
            said = daemon.wait_for("fleet_broker_mqtt311", timeout_s=20.0)
            assert "read before it is refused" in said["effect"]
            assert daemon.wait_for("fleet_connected", timeout_s=20.0)["mqtt"] == "3.1.1"
            assert (await _connection_states(client, until="ONLINE"))[-1] == "ONLINE"
            assert not [line for line in daemon.seen if line["event"] == "fleet_connect_failed"]
        assert (gate.refused, gate.passed) == (1, 1)
    finally:
        gate.stop()
        broker.stop()


async def _connection_states(client: Any, until: str, limit_s: float = 20.0) -> list[str]:
    """Connection states heard (each checked against its schema) up to ``until``."""
    states: list[str] = []
    async with asyncio.timeout(limit_s):
        async for message in client.messages:
            body = json.loads(message.payload)
            check("connection", body)
            states.append(body["connectionState"])
            if states[-1] == until:
                return states
    return states


# An empty hall, 10 x 6 m: nothing for the lidar to see between the robot and its goal.
HALL = {
    "walls": [[-1.0, -1.0, 11.0, -1.0], [11.0, -1.0, 11.0, 6.0], [11.0, 6.0, -1.0, 6.0],
              [-1.0, 6.0, -1.0, -1.0]],
    "start": [1.0, 2.5, 0.0],
}  # fmt: skip
GHOST = (5.0, 2.5)  # another vehicle of the fleet, standing on the straight way


async def test_another_vehicle_of_the_fleet_is_driven_around(tmp_path: Path) -> None:
    broker = Broker(tmp_path)
    broker.start()
    try:
        async with aiomqtt.Client("127.0.0.1", broker.port, identifier="ghost") as ghost:
            sheet = {
                "headerId": 0, "timestamp": "2026-12-02T08:00:00.00Z", "version": "2.1.0",
                "manufacturer": "other", "serialNumber": "ghost",
                "physicalParameters": {"length": 0.8, "width": 0.6},
            }  # fmt: skip
            await ghost.publish("uagv/v2/other/ghost/factsheet", json.dumps(sheet), retain=True)
            async with session(
                from_shapes(HALL, "hall"), tmp_path, overrides=_vehicle(broker), lockstep=True,
                hold_clock=True,
            ) as s:  # fmt: skip
                s.control.send(InitialPoseFrame(x=1.0, y=2.5, yaw=0.0, std_xy=0.02))
                s.sim.release_clock()

                async def stand(n: int) -> None:
                    view = {
                        "headerId": n, "timestamp": "2026-12-02T08:00:00.00Z", "version": "2.1.0",
                        "manufacturer": "other", "serialNumber": "ghost",
                        "agvPosition": {"x": GHOST[0], "y": GHOST[1], "theta": 0.0,
                                        "mapId": "map", "positionInitialized": True},
                    }  # fmt: skip
                    check("visualization", view)
                    await ghost.publish("uagv/v2/other/ghost/visualization", json.dumps(view))

                for n in range(10):  # heard before the goal is given
                    await stand(n)
                    await asyncio.sleep(0.05)
                s.control.send(GoalFrame(x=9.0, y=2.5, goal_id="across"))
                result: GoalStatusFrame | None = None
                n = 10
                while result is None and s.sim.now() < 120.0:
                    s.check()
                    await stand(n)  # it keeps saying where it stands
                    n += 1
                    try:
                        frame = await s.control.receive(0.2)
                    except TimeoutError:
                        continue
                    if isinstance(frame, GoalStatusFrame) and frame.state != "active":
                        result = frame
                truth = [(x, y) for _, x, y, _ in s.sim.truth]
        assert result is not None and result.state == "reached", result
        # never within the ghost's half diagonal (0.5 m) and the robot's own half width
        nearest = min(math.dist(p, GHOST) for p in truth)
        assert nearest > 0.5 + 0.15, f"passed {nearest:.2f} m from the other vehicle"
    finally:
        broker.stop()


def _tls_files(folder: Path) -> dict[str, Path]:
    """A CA and a server certificate for 127.0.0.1 (openssl), in ``folder``."""
    openssl = shutil.which("openssl")
    if openssl is None:
        pytest.skip("openssl is not installed: no certificates for the TLS broker")
    ca_key, ca, key, csr, cert = (
        folder / n for n in ("ca.key", "ca.pem", "server.key", "server.csr", "server.pem")
    )
    ext = folder / "san.cnf"
    ext.write_text("subjectAltName = IP:127.0.0.1\n")
    run = functools.partial(subprocess.run, check=True, capture_output=True)
    run(
        [
            openssl,
            "req",
            "-x509",
            "-newkey",
            "rsa:2048",
            "-nodes",
            "-keyout",
            str(ca_key),
            "-out",
            str(ca),
            "-days",
            "2",
            "-subj",
            "/CN=navd test CA",
        ]
    )
    run(
        [
            openssl,
            "req",
            "-newkey",
            "rsa:2048",
            "-nodes",
            "-keyout",
            str(key),
            "-out",
            str(csr),
            "-subj",
            "/CN=127.0.0.1",
        ]
    )
    run(
        [
            openssl,
            "x509",
            "-req",
            "-in",
            str(csr),
            "-CA",
            str(ca),
            "-CAkey",
            str(ca_key),
            "-CAcreateserial",
            "-out",
            str(cert),
            "-days",
            "2",
            "-extfile",
            str(ext),
        ]
    )
    return {"ca": ca, "key": key, "cert": cert}


async def test_an_mqtts_broker_with_a_password_is_joined_and_a_wrong_password_named(
    tmp_path: Path, daemon_on_port: Any
) -> None:
    files = _tls_files(tmp_path)
    passwd = shutil.which("mosquitto_passwd") or "/usr/bin/mosquitto_passwd"
    if not Path(passwd).is_file():
        pytest.skip("mosquitto_passwd is not installed")
    users = tmp_path / "users"
    subprocess.run(
        [passwd, "-b", "-c", str(users), "robot-1", "s3cret"], check=True, capture_output=True
    )
    broker = Broker(tmp_path)
    with broker.config.open("a") as conf:
        conf.write(
            f"cafile {files['ca']}\ncertfile {files['cert']}\nkeyfile {files['key']}\n"
            f"password_file {users}\nallow_anonymous false\n"
        )
    broker.start()
    try:
        url = f"mqtts://127.0.0.1:{broker.port}"
        for password, event in (("s3cret", "fleet_connected"), ("wrong", "fleet_connect_failed")):
            toml = (
                f'[fleet]\nenabled = true\nbroker_url = "{url}"\nserial_number = "{SERIAL}"\n'
                f'username = "robot-1"\npassword = "{password}"\nca_file = "{files["ca"]}"\n'
            )
            daemon, _ = daemon_on_port(toml)
            line = daemon.wait_for(event, timeout_s=20.0)
            if event == "fleet_connect_failed":
                assert "authoriz" in line["error"].lower() or "password" in line["error"].lower(), (
                    line
                )
                assert password not in json.dumps(daemon.seen)  # the secret is never logged
            daemon.proc.terminate()
            daemon.proc.wait(10)
    finally:
        broker.stop()
