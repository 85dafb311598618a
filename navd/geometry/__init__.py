"""Robot geometry: poses, angles, sensor mounts, scans as points, the footprint.

The ground floor that slam, estimation, planning and drivers all stand on. Plain values and
pure functions (and the numba kernels other rooms' kernels call: the angle wrap, the
footprint's distance); no asyncio, no bus.
"""

from navd.geometry._angle_kernels import wrap as wrap_angle_kernel
from navd.geometry._footprint_kernels import footprint_distance
from navd.geometry.angles import angle_between, wrap_angle, wrap_angles
from navd.geometry.body_mounts import BodyMounts, ContactMount, DepthMount
from navd.geometry.body_points import band_points, cone_points
from navd.geometry.errors import GeometryError, RasterFileError, UnknownMountError
from navd.geometry.footprint import CIRCLE, Footprint
from navd.geometry.limits import RobotLimits
from navd.geometry.mount import LidarMount, SensorMounts, rotation_rpy
from navd.geometry.pose import IDENTITY, Pose2
from navd.geometry.raster_file import (
    FREE_THRESH,
    OCCUPIED_THRESH,
    MapYaml,
    occupancy_of,
    read_image,
    read_map_yaml,
)
from navd.geometry.scan import (
    ALL_AROUND,
    FieldOfView,
    LaserScanLike,
    ScanPoints,
    laser_points,
    scan_points,
)

__all__ = [
    "ALL_AROUND",
    "CIRCLE",
    "FREE_THRESH",
    "IDENTITY",
    "OCCUPIED_THRESH",
    "BodyMounts",
    "ContactMount",
    "DepthMount",
    "FieldOfView",
    "Footprint",
    "GeometryError",
    "LaserScanLike",
    "LidarMount",
    "MapYaml",
    "Pose2",
    "RasterFileError",
    "RobotLimits",
    "ScanPoints",
    "SensorMounts",
    "UnknownMountError",
    "angle_between",
    "band_points",
    "cone_points",
    "footprint_distance",
    "laser_points",
    "occupancy_of",
    "read_image",
    "read_map_yaml",
    "rotation_rpy",
    "scan_points",
    "wrap_angle",
    "wrap_angle_kernel",
    "wrap_angles",
]
