"""Robot geometry: poses, angles, sensor mounts, scans as points, the footprint.

The ground floor that slam, estimation, planning and drivers all stand on. Plain values and
pure functions (and one numba twin of the angle wrap for kernels); no asyncio, no bus.
"""

from navd.geometry.angles import angle_between, wrap_angle, wrap_angles
from navd.geometry.footprint import Footprint
from navd.geometry.mount import LidarMount
from navd.geometry.pose import IDENTITY, Pose2
from navd.geometry.scan import LaserScanLike, ScanPoints, laser_points, scan_points

__all__ = [
    "IDENTITY",
    "Footprint",
    "LaserScanLike",
    "LidarMount",
    "Pose2",
    "ScanPoints",
    "angle_between",
    "laser_points",
    "scan_points",
    "wrap_angle",
    "wrap_angles",
]
