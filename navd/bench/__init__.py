"""Benchmarks behind ``navd bench``: each prints the figures an issue asks for.

Each benchmark is a module of its own with a ``run`` that returns its figures, imported only
when asked for (it imports what it times); the others are the programs and fixtures they
start (a sensor client, a viewer, a synthetic room, the reference UKF); the device
emulators they read are ``navd.sim.devices``.
"""

__all__ = [
    "compare",
    "estimation",
    "fleet",
    "ingest",
    "lidar_program",
    "order_reading",
    "planning",
    "safety",
    "scan",
]
