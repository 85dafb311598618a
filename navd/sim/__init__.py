"""The simulator: a robot that speaks the real protocols (the chassis pty and TCP sensors).

Its members load when asked for (a benchmark that starts a broker does not load the
simulated robot's kernels).
"""

from typing import TYPE_CHECKING

from navd.lazy_face import lazy_members
from navd.sim.errors import SimError, WorldError

if TYPE_CHECKING:
    from navd.sim.barn import run_barn
    from navd.sim.broker import LocalBroker, mosquitto_path
    from navd.sim.demo import run_demo
    from navd.sim.fleet import fleet_sessions
    from navd.sim.fleet_demo import OFFICE_ANCHORS, office_with_beacons, on_beacons, run_fleet_demo
    from navd.sim.ports import free_port
    from navd.sim.sim_session import Session, session
    from navd.sim.standalone import run_sim
    from navd.sim.world import World, from_shapes, load_world, office

__getattr__ = lazy_members(
    __name__,
    {
        "LocalBroker": "broker",
        "OFFICE_ANCHORS": "fleet_demo",
        "Session": "sim_session",
        "World": "world",
        "fleet_sessions": "fleet",
        "free_port": "ports",
        "from_shapes": "world",
        "load_world": "world",
        "mosquitto_path": "broker",
        "office": "world",
        "office_with_beacons": "fleet_demo",
        "on_beacons": "fleet_demo",
        "run_barn": "barn",
        "run_demo": "demo",
        "run_fleet_demo": "fleet_demo",
        "run_sim": "standalone",
        "session": "sim_session",
    },
)

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
