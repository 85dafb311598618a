"""SLAM over recorded logs, away from the robot: the log readers (CARMEN, ROS bags), the
replay, the fine refinement of its trajectory, the relation metric, the perturbations and
the map picture. Nothing here runs in the daemon."""

from navd.offline.errors import LogFormatError, OfflineError
from navd.offline.logfiles import LogScan, open_log
from navd.offline.perturb import perturb
from navd.offline.picture import encode_png
from navd.offline.relations import evaluate, read_relations, read_tum
from navd.offline.replay import open_recording, replay, replay_mount
from navd.offline.warmup import warm_up

__all__ = [
    "LogFormatError",
    "LogScan",
    "OfflineError",
    "encode_png",
    "evaluate",
    "open_log",
    "open_recording",
    "perturb",
    "read_relations",
    "read_tum",
    "replay",
    "replay_mount",
    "warm_up",
]
