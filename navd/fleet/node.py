"""The fleet module: navd as a VDA 5050 2.1 vehicle on an MQTT broker.

It keeps one connection to the broker (aiomqtt), reconnecting with a growing pause when it
is lost; its ``connection`` topic says ONLINE once connected, OFFLINE when navd stops, and
CONNECTIONBROKEN through the broker (the last will) when the connection breaks. Orders and
instant actions come in on the vehicle's topics and go to ``vehicle.Vehicle``, whose goals
go on the bus like anyone's, through the same planner and safety gate. The state goes out on
every change, the robot starting or stopping included (at most every ``MIN_STATE_S``), and
at least every ``fleet.state_interval_s``; the position at ``fleet.visualization_rate_hz``;
the factsheet on connecting and on request.
While the broker is gone the order goes on or the robot holds (``fleet.on_broker_lost``).

It also hears the other vehicles of its interface (their visualization, and their factsheet
for their size) and tells the planner where those on its map are (``NearbyRobots``), so two
robots in one corridor give way to each other; one silent for ``others.STALE_S`` is forgotten.
"""

from __future__ import annotations

import asyncio
import json
import math
import time
from typing import Any

import aiomqtt
from pydantic import ValidationError

from navd.fleet import reports
from navd.fleet.mqtt import Broker, connect, refused_mqtt5
from navd.fleet.order_reading import read_order
from navd.fleet.others import OtherVehicles
from navd.fleet.settings import FleetSettings
from navd.fleet.standing_room import StandingRoom
from navd.fleet.vda5050 import PROTOCOL_VERSION, Order, Topics
from navd.fleet.vehicle import Vehicle
from navd.geometry import Pose2
from navd.lifecycle import Module, ModuleContext
from navd.lifecycle.messages import GoalStatus, MapUpdate, Message, NearbyRobots, RobotState

__all__ = ["FleetNode"]

MIN_STATE_S = 0.1  # [s] state messages at most this often (a burst of changes is one)
TICK_S = 0.1  # [s] the vehicle's clock (waits) and the publishing checks
POSE_FRESH_S = 1.0  # [s] an older pose says nothing of whether the robot stands
FIRST_RETRY_S = 0.5  # [s] the first pause before reconnecting; it doubles up to MAX_RETRY_S
MAX_RETRY_S = 10.0
# a message up to this many times fleet.max_message_bytes is sent by an MQTT 5 broker, and
# refused with a validationError the master sees; a larger one the broker drops unsent
SENT_UP_TO = 4
# §6.2: QoS 0 for every topic but ``connection`` (QoS 1, retained, and the last will)
QOS = 0
CONNECTION_QOS = 1


class FleetNode(Module):
    """The VDA 5050 vehicle (see the module docstring)."""

    def __init__(self) -> None:
        super().__init__("fleet")
        self._state = RobotState(stamp=0.0, received=0.0, changed=frozenset())
        self._headers: dict[str, int] = {}
        self._client: aiomqtt.Client | None = None
        self._state_due = True
        self._last_state_s = -math.inf
        # (driving, position known, safety holds, manual) as the last state message said them
        self._told: tuple[object, ...] = ()
        self._motion = reports.Motion()  # whether the robot drives, with hysteresis
        self._next_view_s = -math.inf  # [s] when the next visualization is due
        self.connected = asyncio.Event()
        self._others = OtherVehicles()
        self._failure = ""  # why the broker was last out of reach (logged once per reason)
        self._malformed = 0  # other vehicles' messages that could not be read

    async def on_configure(self, ctx: ModuleContext) -> None:
        self.ctx = ctx
        self.settings = ctx.settings(FleetSettings.from_config)
        fleet = self.settings.value.fleet  # broker and names need a restart
        self.topics = Topics(fleet.interface_name, fleet.manufacturer, fleet.serial_number)
        self.vehicle = Vehicle(fleet.manufacturer, fleet.serial_number, self._requested)
        self._spoken = self._version()  # the version of what was sent last
        room = StandingRoom(self.settings.value.footprint.inscribed_m)  # where it fits on the map
        self.vehicle.blocked = room.blocked
        ctx.subscribe(MapUpdate, room.take)
        ctx.subscribe(RobotState, self._on_state)
        ctx.subscribe(GoalStatus, self._on_goal_status)

    async def on_activate(self) -> None:
        self.ctx.spawn(self._connection(), name="broker")
        self.ctx.every(TICK_S, self._tick, name="vehicle")

    async def on_deactivate(self) -> None:
        client = self._client
        if client is not None:  # a clean goodbye: OFFLINE, not the last will
            try:
                await asyncio.wait_for(
                    client.publish(
                        self.topics.connection,
                        self._json("connection", reports.connection, "OFFLINE"),
                        qos=CONNECTION_QOS,
                        retain=True,
                    ),
                    1.0,
                )
            except (aiomqtt.MqttError, TimeoutError) as err:
                self.ctx.log.warning("fleet_offline_unsent", error=str(err))

    def settings_in_use(self) -> tuple[object, ...]:
        return (self.settings.value,)

    # --- the bus --------------------------------------------------------------------------

    def _publish(self, messages: list[Message]) -> None:
        for message in messages:
            self.ctx.publish(message)

    def _on_state(self, state: RobotState) -> None:
        """A new view of the robot; a hold or release, or a change of who drives, is a
        change the state message reports (§6.10)."""
        before = self._state
        self._state = state
        if state.held != before.held or state.manual != before.manual:
            self._state_due = True

    def _on_goal_status(self, status: GoalStatus) -> None:
        self._publish(self.vehicle.on_goal_status(status, self.ctx.clock.now()))

    def _here(self) -> Pose2 | None:
        pose = self._state.pose
        return None if pose is None else Pose2(pose.x_m, pose.y_m, pose.yaw_rad)

    def _standing(self, now: float) -> bool:
        """Whether the robot is known to stand: its latest pose says so and is fresh (with
        none, it cannot have driven an order)."""
        pose = self._state.pose
        if pose is None:
            return True
        if now - pose.received > POSE_FRESH_S:
            return False  # not known: a cancel then ends by its deadline
        return not self._motion.driving

    def _robot(self) -> reports.Robot:
        state = self._state
        pose, localization = state.pose, state.localization
        return reports.Robot(
            pose=None if pose is None else (pose.x_m, pose.y_m, pose.yaw_rad),
            position_std_m=math.inf if localization is None else localization.position_std_m,
            velocity=(0.0, 0.0) if pose is None else (pose.linear_mps, pose.angular_radps),
            held=state.held,
            manual=state.manual,
            map_id=self.settings.value.map_id,
            battery=None
            if state.battery is None
            else (state.battery.percentage, state.battery.voltage_v, state.battery.charging),
            driving=self._motion.driving,
        )

    # --- the broker -----------------------------------------------------------------------

    async def _connection(self) -> None:
        """Keep connected: subscribe, announce, hear; reconnect after a growing pause."""
        fleet = self.settings.value.fleet  # the broker and the login need a restart
        broker = Broker.of_url(
            fleet.broker_url,
            username=fleet.username,
            password=fleet.password,
            ca_file=fleet.ca_file,
            cert_file=fleet.cert_file,
            key_file=fleet.key_file,
        )
        will = aiomqtt.Will(
            self.topics.connection,
            self._json("connection", reports.connection, "CONNECTIONBROKEN"),
            qos=CONNECTION_QOS,
            retain=True,
        )
        pause = FIRST_RETRY_S
        largest: int | None = SENT_UP_TO * fleet.max_message_bytes  # None: MQTT 3.1.1
        while True:
            try:
                identifier = f"{fleet.manufacturer}-{fleet.serial_number}"
                async with connect(
                    broker,
                    identifier,
                    will=will,
                    keepalive_s=fleet.keepalive_s,
                    max_packet_bytes=largest,
                ) as client:
                    await self._online(client, mqtt5=largest is not None)
                    pause = FIRST_RETRY_S
                    async for message in client.messages:
                        await self._hear(str(message.topic), message.payload)
            except aiomqtt.MqttError as err:
                if largest is not None and refused_mqtt5(err):
                    largest = None  # a 3.1.1 broker: again at once, in its version
                    self.ctx.log.warning(
                        "fleet_broker_mqtt311",
                        broker=fleet.broker_url,
                        effect="a message over fleet.max_message_bytes is read before it "
                        "is refused (MQTT 5 brokers drop one over "
                        f"{SENT_UP_TO}x that unsent)",
                    )
                    continue
                self._offline(str(err))
            await asyncio.sleep(pause)
            pause = min(2.0 * pause, MAX_RETRY_S)

    async def _online(self, client: aiomqtt.Client, *, mqtt5: bool) -> None:
        await client.subscribe(self.topics.order, qos=QOS)
        await client.subscribe(self.topics.instant_actions, qos=QOS)
        await client.subscribe(self.topics.everyone("visualization"), qos=0)
        await client.subscribe(self.topics.everyone("factsheet"), qos=QOS)
        await client.publish(
            self.topics.connection,
            self._json("connection", reports.connection, "ONLINE"),
            qos=CONNECTION_QOS,
            retain=True,
        )
        await client.publish(self.topics.factsheet, self._factsheet(), qos=QOS, retain=True)
        self._client = client
        self.connected.set()
        self._failure = ""
        self._state_due = True
        broker = self.settings.value.fleet.broker_url
        self.ctx.log.info("fleet_connected", broker=broker, mqtt="5" if mqtt5 else "3.1.1")
        if self.vehicle.held:
            self._publish(self.vehicle.release(self.ctx.clock.now()))

    def _offline(self, why: str) -> None:
        was = self._client is not None
        self._client = None
        self.connected.clear()
        if was:
            hold = self.settings.value.fleet.on_broker_lost == "hold"
            self.ctx.log.warning("fleet_broker_lost", error=why, holding=hold)
            self._failure = why
            if hold:
                self._publish(self.vehicle.hold(self.ctx.clock.now()))
        elif why != self._failure:  # each new reason once, not every retry
            self._failure = why
            broker = self.settings.value.fleet.broker_url
            self.ctx.log.warning("fleet_connect_failed", broker=broker, error=why)

    async def _hear(self, topic: str, payload: Any) -> None:
        """A message from the broker; an order is read in slices between which the loop
        runs (``order_reading``), the next message waiting its turn."""
        raw = payload if isinstance(payload, bytes) else str(payload).encode()
        taken = len(raw) <= self.settings.value.fleet.max_message_bytes
        self._heard(
            topic, raw, await read_order(raw) if taken and topic == self.topics.order else None
        )

    def _heard(self, topic: str, payload: Any, read: Order | ValidationError | None = None) -> None:
        raw = payload if isinstance(payload, bytes) else str(payload).encode()
        now, here = self.ctx.clock.now(), self._here()
        levels = topic.split("/")
        if len(raw) > (limit := self.settings.value.fleet.max_message_bytes):
            self._too_large(topic, levels, len(raw), limit)  # parsing it would hold the loop
            return
        if len(levels) == 5 and levels[-1] in ("visualization", "factsheet"):
            name = f"{levels[2]}/{levels[3]}"
            if name != f"{self.vehicle.manufacturer}/{self.vehicle.serial_number}":
                self._other(name, levels[-1], raw)
            return
        if topic == self.topics.order:
            map_id = self.settings.value.map_id
            self._publish(self.vehicle.on_order(raw, now, here, map_id, read))
        elif topic == self.topics.instant_actions:
            self._publish(self.vehicle.on_instant_actions(raw, now, here))
        if self._version() != self._spoken:
            self._speak(self._version())
        errors = [e["errorType"] for e in self.vehicle.errors]
        if errors:
            self.ctx.log.info("fleet_errors", topic=topic.rsplit("/", 1)[-1], errors=errors)

    def _version(self) -> str:
        """The VDA 5050 version navd speaks: ``fleet.protocol_version``, or with auto the
        master's (2.0 for a 2.0 master, else 2.1)."""
        chosen = self.settings.value.fleet.protocol_version
        if chosen != "auto":
            return chosen
        return "2.0.0" if self.vehicle.master_version.startswith("2.0") else PROTOCOL_VERSION

    def _speak(self, version: str) -> None:
        """The master speaks another version: say again, in it, that the vehicle is online,
        its factsheet, and its state."""
        self.ctx.log.info("fleet_protocol_version", version=version, was=self._spoken)
        self._spoken = version
        online = self._json("connection", reports.connection, "ONLINE")
        said = self._send(self.topics.connection, online, retain=True, qos=CONNECTION_QOS)
        self.ctx.spawn(said, name="online")
        self.ctx.spawn(self._send(self.topics.factsheet, self._factsheet(), retain=True), name="f")
        self._state_due = True

    def _too_large(self, topic: str, levels: list[str], size: int, limit: int) -> None:
        """A message over ``fleet.max_message_bytes``: refused without reading it."""
        self.ctx.log.warning("fleet_message_too_large", topic=topic, bytes=size, limit=limit)
        if topic in (self.topics.order, self.topics.instant_actions):
            self.vehicle.refuse_unread(levels[-1], size, limit)

    def _requested(self, what: str) -> None:
        if what == "state":
            self._state_due = True
        else:
            factsheet = self._send(self.topics.factsheet, self._factsheet(), retain=True)
            self.ctx.spawn(factsheet, name="factsheet")

    def _other(self, name: str, topic: str, raw: bytes) -> None:
        """Another vehicle's position (on our map) or size; anything malformed is ignored."""
        try:
            map_id = self.settings.value.map_id
            self._others.hear(name, topic, raw, map_id, time.monotonic())
        except (ValueError, KeyError, TypeError, AttributeError, RecursionError) as err:
            self._malformed += 1
            if self._malformed == 1 or self._malformed % 1000 == 0:  # seen, not flooded
                self.ctx.log.warning(
                    "fleet_other_ignored", vehicle=name, topic=topic, error=str(err),
                    count=self._malformed,
                )  # fmt: skip

    def _tell_others(self, now: float) -> None:
        """The planner hears where the other vehicles are (the stale ones dropped)."""
        robots = self._others.nearby(time.monotonic(), self.settings.value.radius_m)
        if robots is not None:
            self.ctx.publish(NearbyRobots(stamp=now, received=now, robots=robots))

    # --- publishing -----------------------------------------------------------------------

    def _tick(self, now: float) -> None:
        pose = self._state.pose
        moving = (0.0, 0.0) if pose is None else (pose.linear_mps, pose.angular_radps)
        self._motion.update(*moving, now)
        self._publish(self.vehicle.on_tick(now, standing=self._standing(now)))
        self._tell_others(now)
        client = self._client
        if client is None:
            return
        fleet = self.settings.value.fleet
        wall = time.monotonic()
        robot = self._robot()
        # starting and stopping, the position becoming known, a hold, the mode: changes too
        told = (robot.driving, robot.pose is not None, robot.held, robot.manual)  # (§6.10)
        due = self._state_due or self.vehicle.changed or told != self._told
        if (due and wall - self._last_state_s >= MIN_STATE_S) or (
            wall - self._last_state_s >= fleet.state_interval_s
        ):
            self._state_due = self.vehicle.changed = False
            self._told = told
            self._last_state_s = wall
            payload = self._json("state", reports.state, self.vehicle, robot)
            self.ctx.spawn(self._send(self.topics.state, payload), name="state")
        rate = fleet.visualization_rate_hz
        if rate > 0 and wall >= self._next_view_s:
            # due a period after the last was due (not sent): the rate is the factsheet's,
            # not rounded up to the tick; a late start begins anew
            period = 1.0 / rate
            late = wall - self._next_view_s >= period
            self._next_view_s = wall + period if late else self._next_view_s + period
            payload = self._json("visualization", reports.visualization, self._robot())
            self.ctx.spawn(self._send(self.topics.visualization, payload), name="visualization")

    async def _send(
        self, topic: str, payload: bytes, *, retain: bool = False, qos: int = QOS
    ) -> None:
        client = self._client
        if client is None:
            return
        try:
            await client.publish(topic, payload, qos=qos, retain=retain)
        except aiomqtt.MqttError as err:  # the connection task hears of it and reconnects
            self.ctx.log.debug("fleet_send_failed", topic=topic, error=str(err))

    def _json(self, topic: str, build: Any, *args: Any) -> bytes:
        """``build(header, *args)`` as JSON, with the topic's next header id."""
        fleet = self.settings.value.fleet
        number = self._headers.get(topic, 0)
        self._headers[topic] = number + 1
        head = reports.header(
            number, time.time(), fleet.manufacturer, fleet.serial_number, self._version()
        )
        return json.dumps(build(head, *args), separators=(",", ":")).encode()

    def _factsheet(self) -> bytes:
        settings = self.settings.value
        return self._json(
            "factsheet", reports.factsheet, settings.fleet, settings.limits, settings.footprint
        )
