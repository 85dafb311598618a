"""Which modules the daemon runs, in start order: the one place the layers are wired."""

from __future__ import annotations

from navd.config import NavdConfig
from navd.drivers.chassis import ChassisDriver
from navd.drivers.tcp.server import TcpServer
from navd.estimation.node import EstimationNode
from navd.lifecycle.module import Module
from navd.lifecycle.safety import SafetyGate
from navd.planning.guard import CollisionGuard
from navd.planning.node import PlannerNode
from navd.slam.node import SlamNode

__all__ = ["build_modules"]


def build_modules(config: NavdConfig) -> list[Module]:
    """The modules for ``config``, in start order (they stop in reverse).

    The safety gate starts first and stops last, so every command passes it (and the
    collision guard it asks); the chassis starts last and stops first, writing "0 0" before
    anything else goes away.
    """
    guard = CollisionGuard()
    modules: list[Module] = [
        SafetyGate(limiters=(guard,)),
        guard,
        EstimationNode(),
        SlamNode(),
        PlannerNode(),
        TcpServer(),
    ]
    if config.chassis.enabled:
        modules.append(ChassisDriver())
    return modules
