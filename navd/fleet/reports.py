"""What the vehicle tells the fleet control: its state, visualization, connection and
factsheet messages as VDA 5050 2.1 JSON objects, from the vehicle's order state and what the
robot is doing."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from navd.config import FleetConfig
from navd.fleet.action_states import INSTANT_ACTIONS
from navd.fleet.vda5050 import PROTOCOL_VERSION, Node, timestamp
from navd.fleet.vehicle import Vehicle
from navd.geometry import Footprint, RobotLimits
from navd.lifecycle import ESTOP_REASON

__all__ = ["Motion", "Robot", "connection", "factsheet", "state", "visualization"]

# [m/s, rad/s] slower than this the vehicle counts as standing (``driving`` false) once it
# has been for STILL_S [s]; faster than START it drives. Between them nothing changes: a
# standing robot's velocity estimate wanders up to 0.012 m/s, which must not read as driving.
STANDING_MPS = 0.01
STANDING_RADPS = 0.02
START_MPS = 0.03
START_RADPS = 0.06
STILL_S = 0.5
# [m] position std at which the localization score reaches 0 (1 at 0 m).
SCORE_ZERO_STD_M = 1.0


@dataclass(frozen=True, slots=True)
class Robot:
    """What the robot is doing, for the state and visualization messages.

    Attributes:
        pose: [m, m, rad] the fused pose in the map frame, or None before localization.
        position_std_m: [m] its position uncertainty.
        velocity: [m/s, rad/s] forward and turning speed.
        held: why the safety gate holds the robot (empty: it does not).
        manual: an operator drives by hand.
        map_id: the map the pose is on.
        battery: [0, 1] charge, [V], charging, or None without a battery sensor (charge
            and charging may be NaN and None when the sensor does not say).
        driving: it drives (``Motion``).
    """

    pose: tuple[float, float, float] | None
    position_std_m: float
    velocity: tuple[float, float]
    held: tuple[str, ...]
    manual: bool
    map_id: str
    battery: tuple[float, float, bool | None] | None = None
    driving: bool = False


def header(
    header_id: int,
    now_unix_s: float,
    manufacturer: str,
    serial: str,
    version: str = PROTOCOL_VERSION,
) -> dict[str, Any]:
    """The protocol header every message starts with (``version``: the VDA 5050 version
    the master is spoken to in)."""
    return {
        "headerId": header_id,
        "timestamp": timestamp(now_unix_s),
        "version": version,
        "manufacturer": manufacturer,
        "serialNumber": serial,
    }


def _position(robot: Robot) -> dict[str, Any] | None:
    if robot.pose is None:
        return None
    x, y, yaw = robot.pose
    std = robot.position_std_m
    score = max(0.0, 1.0 - std / SCORE_ZERO_STD_M) if math.isfinite(std) else 0.0
    return {
        "x": x,
        "y": y,
        "theta": math.remainder(yaw, math.tau),
        "mapId": robot.map_id,
        "positionInitialized": True,
        "localizationScore": round(score, 3),
        "deviationRange": round(std, 3) if math.isfinite(std) else 0.0,
    }


class Motion:
    """Whether the robot drives, with hysteresis (see START_MPS and STILL_S): it starts
    driving the moment it is faster than the start thresholds, and stands once it has been
    slower than the standing ones for STILL_S."""

    def __init__(self) -> None:
        self.driving = False
        self._still_since: float | None = None

    def update(self, linear_mps: float, angular_radps: float, now: float) -> bool:
        """Take the velocity at ``now`` [s]; whether the robot drives."""
        v, w = abs(linear_mps), abs(angular_radps)
        if v > START_MPS or w > START_RADPS:
            self.driving, self._still_since = True, None
        elif v <= STANDING_MPS and w <= STANDING_RADPS:
            if self._still_since is None:
                self._still_since = now
            if now - self._still_since >= STILL_S:
                self.driving = False
        else:
            self._still_since = None
        return self.driving


def order_fields(vehicle: Vehicle) -> dict[str, Any]:
    """The state message's order fields (its other fields are the node's)."""
    return {
        "orderId": vehicle.order_id,
        "orderUpdateId": vehicle.order_update_id,
        "lastNodeId": vehicle.last_node_id,
        "lastNodeSequenceId": vehicle.last_node_sequence_id,
        "nodeStates": [_node_state(n) for n in vehicle.nodes],
        "edgeStates": [
            {"edgeId": e.edgeId, "sequenceId": e.sequenceId, "released": e.released}
            for e in vehicle.edges
        ],
        "actionStates": [
            {
                "actionId": s.action.actionId,
                "actionType": s.action.actionType,
                "actionStatus": s.status,
                **({"resultDescription": s.result} if s.result else {}),
            }
            for s in vehicle.actions.values()
        ],
        "paused": vehicle.paused,
        "errors": list(vehicle.errors),
    }


def _node_state(node: Node) -> dict[str, Any]:
    state: dict[str, Any] = {
        "nodeId": node.nodeId,
        "sequenceId": node.sequenceId,
        "released": node.released,
    }
    if node.nodePosition is not None:
        state["nodePosition"] = node.nodePosition.model_dump(exclude_none=True)
    return state


def _battery_state(robot: Robot) -> dict[str, Any]:
    """batteryState: the charge [%] and the voltage as the sensor says (the field is
    required: without a battery sensor, or a charge it says, 100 %, and ``information``
    says it is not measured)."""
    if robot.battery is None:
        return {"batteryCharge": 100.0, "charging": False}
    charge, voltage, charging = robot.battery
    state: dict[str, Any] = {
        "batteryCharge": round(charge * 100.0, 1) if math.isfinite(charge) else 100.0,
        "batteryVoltage": round(voltage, 2),
        "charging": bool(charging),
    }
    return state


def _battery_unknown(robot: Robot) -> list[dict[str, str]]:
    battery = robot.battery
    if battery is not None and math.isfinite(battery[0]):
        return []
    why = "no battery sensor" if battery is None else "the battery sensor gives no charge"
    return [
        {
            "infoType": "batteryUnknown",
            "infoLevel": "INFO",
            "infoDescription": f"{why}: batteryCharge is not measured",
        }
    ]


def state(head: dict[str, Any], vehicle: Vehicle, robot: Robot) -> dict[str, Any]:
    """The state message."""
    v, w = robot.velocity
    message: dict[str, Any] = {
        **head,
        **order_fields(vehicle),
        "driving": robot.driving,
        "operatingMode": "MANUAL" if robot.manual else "AUTOMATIC",
        "batteryState": _battery_state(robot),
        "information": [
            *_battery_unknown(robot),
            *(
                {"infoType": "safetyHold", "infoLevel": "INFO", "infoDescription": why}
                for why in robot.held
            ),
        ],
        "safetyState": {
            # an operator's emergency stop, from a control client or the page: REMOTE
            "eStop": "REMOTE" if any(r.startswith(ESTOP_REASON) for r in robot.held) else "NONE",
            "fieldViolation": bool(robot.held),
        },
        "velocity": {"vx": v, "vy": 0.0, "omega": w},
    }
    position = _position(robot)
    if position is not None:
        message["agvPosition"] = position
    return message


def visualization(head: dict[str, Any], robot: Robot) -> dict[str, Any]:
    """The visualization message: the position and velocity only."""
    v, w = robot.velocity
    message: dict[str, Any] = {**head, "velocity": {"vx": v, "vy": 0.0, "omega": w}}
    position = _position(robot)
    if position is not None:
        message["agvPosition"] = position
    return message


def connection(head: dict[str, Any], connection_state: str) -> dict[str, Any]:
    """The connection message: ONLINE, OFFLINE or CONNECTIONBROKEN (the last will)."""
    return {**head, "connectionState": connection_state}


def factsheet(
    head: dict[str, Any], fleet: FleetConfig, limits: RobotLimits, footprint: Footprint
) -> dict[str, Any]:
    """The factsheet: what the vehicle is and which of the protocol it speaks."""
    length, width = 2.0 * footprint.half_length_m, 2.0 * footprint.half_width_m
    return {
        **head,
        "typeSpecification": {
            "seriesName": "navd",
            "seriesDescription": "a navd robot: differential drive, free navigation",
            "agvKinematic": "DIFF",
            "agvClass": "CARRIER",
            "maxLoadMass": 0.0,
            "localizationTypes": ["NATURAL"],
            "navigationTypes": ["AUTONOMOUS"],
        },
        "physicalParameters": {
            "speedMin": 0.0,
            "speedMax": limits.max_forward_mps,
            "accelerationMax": limits.max_linear_accel_mps2,
            "decelerationMax": limits.max_linear_accel_mps2,
            "heightMax": 0.5,
            "width": width,
            "length": length,
        },
        "protocolLimits": {
            "maxStringLens": {"msgLen": fleet.max_message_bytes, "idLen": 256},
            "maxArrayLens": {"order.nodes": 1000, "order.edges": 1000},
            "timing": {
                "minOrderInterval": 0.1,
                "minStateInterval": 0.1,
                "defaultStateInterval": fleet.state_interval_s,
                "visualizationInterval": (
                    1.0 / fleet.visualization_rate_hz if fleet.visualization_rate_hz > 0 else 0.0
                ),
            },
        },
        "protocolFeatures": {
            "optionalParameters": [
                {"parameter": "order.nodes.nodePosition.theta", "support": "SUPPORTED"},
                {"parameter": "order.edges.maxSpeed", "support": "SUPPORTED"},
            ],
            "agvActions": [
                {
                    "actionType": "wait",
                    "actionDescription": "stand still for duration seconds",
                    "actionScopes": ["NODE", "EDGE"],
                    "actionParameters": [
                        {
                            "key": "duration",
                            "valueDataType": "FLOAT",
                            "description": "[s] how long to wait",
                        }
                    ],
                },
                *({"actionType": kind, "actionScopes": ["INSTANT"]} for kind in INSTANT_ACTIONS),
            ],
        },
        "agvGeometry": {},
        "loadSpecification": {},
    }
