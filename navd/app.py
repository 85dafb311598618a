"""Which modules the daemon runs, in start order: the one place the layers are wired."""

from __future__ import annotations

from navd.config import NavdConfig
from navd.drivers import ChassisDriver, TcpServer
from navd.estimation import EstimationNode
from navd.lifecycle import BatteryWatch, Module, SafetyGate
from navd.missions import MissionNode
from navd.planning import CollisionGuard, PlannerNode
from navd.slam import SlamNode
from navd.viz import Recorder, VizNode

__all__ = ["build_modules"]


def build_modules(config: NavdConfig) -> list[Module]:
    """The modules for ``config``, in start order (they stop in reverse).

    The collision guard, then the safety gate that asks it, start first and stop last, so
    every command passes them (the guard takes each scan before the gate sweeps the command
    in force with it); the chassis starts last and stops first, writing "0 0" before anything
    else goes away.
    """
    guard = CollisionGuard()
    modules: list[Module] = [
        guard,
        SafetyGate(limiters=(guard,)),
        # before anything that decides or hears: a recording from start-up misses nothing,
        # and stops after them
        Recorder(),
        EstimationNode(),
        SlamNode(),
        PlannerNode(),
        BatteryWatch(),
        MissionNode(),  # stops before the planner: its goal is cancelled while it listens
        TcpServer(),
    ]
    if config.viz.enabled:
        modules.append(VizNode())
    if config.fleet.enabled:
        from navd.fleet import FleetNode  # noqa: PLC0415 - MQTT loads only for a fleet

        modules.append(FleetNode())
    if config.chassis.enabled:
        modules.append(ChassisDriver())
    return modules
