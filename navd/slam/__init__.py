"""SLAM: scans to points, correlative scan matching, occupancy grid, loop closure, map files.

No asyncio here: plain computation that ``node.SlamNode`` runs in worker threads, and that
``navd replay`` runs over log files.
"""

from navd.slam.errors import MapFileError, SlamError
from navd.slam.global_search import relocalize
from navd.slam.keyframe import Keyframe
from navd.slam.likelihood_field import LikelihoodField
from navd.slam.map_io import SavedMap, load_map, load_map_state, save_map
from navd.slam.mapper import EDGE_WEIGHTS, ScanMapper
from navd.slam.matcher import CorrelativeMatcher
from navd.slam.node import SlamNode
from navd.slam.occupancy import OccupancyGrid
from navd.slam.odometry import ScanOdometry, ScanOdometrySettings
from navd.slam.pose_graph import Edge, optimize
from navd.slam.settings import MapperSettings, scan_odometry_settings
from navd.slam.voxel import voxel_downsample
from navd.slam.warmup import warm_up

__all__ = [
    "EDGE_WEIGHTS",
    "CorrelativeMatcher",
    "Edge",
    "Keyframe",
    "LikelihoodField",
    "MapFileError",
    "MapperSettings",
    "OccupancyGrid",
    "SavedMap",
    "ScanMapper",
    "ScanOdometry",
    "ScanOdometrySettings",
    "SlamError",
    "SlamNode",
    "load_map",
    "load_map_state",
    "optimize",
    "relocalize",
    "save_map",
    "scan_odometry_settings",
    "voxel_downsample",
    "warm_up",
]
