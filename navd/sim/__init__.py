"""The simulator: a robot that speaks the real protocols (the chassis pty and TCP sensors)."""

from navd.sim.barn import run_barn
from navd.sim.broker import LocalBroker, mosquitto_path
from navd.sim.demo import run_demo
from navd.sim.errors import SimError, WorldError
from navd.sim.fleet import fleet_sessions
from navd.sim.fleet_demo import OFFICE_ANCHORS, office_with_beacons, on_beacons, run_fleet_demo
from navd.sim.session import Session, free_port, session
from navd.sim.standalone import run_sim
from navd.sim.world import World, from_shapes, load_world, office

__all__ = [
    "OFFICE_ANCHORS",
    "LocalBroker",
    "Session",
    "SimError",
    "World",
    "WorldError",
    "fleet_sessions",
    "free_port",
    "from_shapes",
    "load_world",
    "mosquitto_path",
    "office",
    "office_with_beacons",
    "on_beacons",
    "run_barn",
    "run_demo",
    "run_fleet_demo",
    "run_sim",
    "session",
]
