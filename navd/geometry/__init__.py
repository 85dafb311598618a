"""Robot geometry: poses, angles, sensor mounts, scans as points, the footprint.

The ground floor that slam, estimation, planning and drivers all stand on. Plain values and
pure functions (and the numba kernels other rooms' kernels call: the angle wrap, the
footprint's distance); no asyncio, no bus.
"""

from navd.geometry._angle_kernels import wrap as wrap_angle_kernel
from navd.geometry._footprint_kernels import footprint_distance
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
    "footprint_distance",
    "laser_points",
    "scan_points",
    "wrap_angle",
    "wrap_angle_kernel",
    "wrap_angles",
]
