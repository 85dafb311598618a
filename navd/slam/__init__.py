"""SLAM: scans to points, ICP odometry, correlative scan matching, occupancy grid, map files.

No asyncio here: plain computation that the lifecycle layer runs in worker threads.
"""

from navd.slam.errors import SlamError

__all__ = ["SlamError"]
