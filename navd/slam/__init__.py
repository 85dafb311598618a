"""SLAM: scans to points, correlative scan matching, occupancy grid, loop closure, map files.

No asyncio here: plain computation that ``node.SlamNode`` runs in worker threads, and that
``navd replay`` runs over log files.
"""

from navd.slam.errors import MapFileError, SlamError
from navd.slam.global_search import relocalize
from navd.slam.keyframe import EDGE_WEIGHTS, Keyframe
from navd.slam.likelihood_field import LikelihoodField
from navd.slam.map_io import SavedMap, load_map, load_map_state, save_map
from navd.slam.mapper import ScanMapper
from navd.slam.matcher import CorrelativeMatcher
from navd.slam.motion_check import Jump, MotionLimits, jumps
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
    "Jump",
    "Keyframe",
    "LikelihoodField",
    "MapFileError",
    "MapperSettings",
    "MotionLimits",
    "OccupancyGrid",
    "SavedMap",
    "ScanMapper",
    "ScanOdometry",
    "ScanOdometrySettings",
    "SlamError",
    "SlamNode",
    "jumps",
    "load_map",
    "load_map_state",
    "optimize",
    "relocalize",
    "save_map",
    "scan_odometry_settings",
    "voxel_downsample",
    "warm_up",
]
