"""SLAM: scans to points, correlative scan matching, occupancy grid, loop closure, map files.

No asyncio here: plain computation that ``node.SlamNode`` runs in worker threads, and that
``navd replay`` runs over log files.
"""

from navd.slam.errors import MapFileError, SlamError
from navd.slam.mapper import ScanMapper
from navd.slam.occupancy import OccupancyGrid
from navd.slam.settings import MapperSettings

__all__ = [
    "MapFileError",
    "MapperSettings",
    "OccupancyGrid",
    "ScanMapper",
    "SlamError",
]
