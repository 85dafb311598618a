"""Laser logs for replay: the plain-text dumps of the Freiburg benchmark, and CARMEN logs
(ROS bags are read by ``navd.offline.bags``).

Every reader yields ``LogScan``: a scan in the LaserScan sense plus the odometry pose at its
stamp (interpolated between odometry samples), or None when the log has none.
"""

from __future__ import annotations

import bisect
import gzip
import math
import zlib
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import TextIO

import numpy as np
import numpy.typing as npt

from navd.geometry import Pose2
from navd.offline.errors import LogFormatError

__all__ = [
    "LogScan",
    "OdometryTrack",
    "count_scans",
    "open_log",
    "read_carmen",
    "read_text_dump",
]


@dataclass(frozen=True, slots=True)
class LogScan:
    """One laser scan of a log, with the odometry pose at its stamp."""

    stamp: float
    angle_min: float
    angle_increment: float
    range_min: float
    range_max: float
    ranges: npt.NDArray[np.float64]
    odom: Pose2 | None


def _open_text(path: Path) -> TextIO:
    if path.suffix == ".gz":
        return gzip.open(path, "rt", encoding="ascii")
    return path.open("r", encoding="ascii")


def _lines(path: Path) -> Iterator[tuple[int, str]]:
    """The numbered lines of a text log (gzipped or not).

    Raises:
        LogFormatError: the file is not ASCII text, is cut short or damaged, or cannot be
            read (the file, and the line reached, named).
    """
    number = 0
    try:
        with _open_text(path) as f:
            for number, line in enumerate(f, 1):
                yield number, line
    except UnicodeDecodeError as err:
        raise LogFormatError(f"{path}:{number + 1}: not ASCII text ({err.reason})") from err
    except (EOFError, gzip.BadGzipFile, zlib.error) as err:
        raise LogFormatError(f"{path}: cut short or damaged after line {number}: {err}") from err
    except OSError as err:
        raise LogFormatError(f"{path}: cannot be read: {err}") from err


def _numbers(line: str, path: Path, number: int) -> list[float]:
    try:
        return [float(v) for v in line.split()]
    except ValueError as err:
        raise LogFormatError(f"{path}:{number}: not a line of numbers: {line[:60]!r}") from err


def _finite(values: Iterable[float], what: str, path: Path, number: int) -> None:
    """Raise unless every value is a finite number (stamps, poses, angles; ranges may be inf)."""
    if not all(math.isfinite(v) for v in values):
        raise LogFormatError(f"{path}:{number}: {what} must be finite numbers")


class OdometryTrack:
    """Odometry poses by time, interpolated (yaw on the circle)."""

    def __init__(self, stamps: list[float], poses: list[Pose2]) -> None:
        self.stamps = stamps
        self.poses = poses

    def at(self, stamp: float) -> Pose2 | None:
        if not self.stamps:
            return None
        i = bisect.bisect_left(self.stamps, stamp)
        if i == 0:
            return self.poses[0]
        if i == len(self.stamps):
            return self.poses[-1]
        t0, t1 = self.stamps[i - 1], self.stamps[i]
        a, b = self.poses[i - 1], self.poses[i]
        w = 0.0 if t1 == t0 else (stamp - t0) / (t1 - t0)
        dyaw = math.remainder(b.yaw - a.yaw, 2.0 * math.pi)
        return Pose2(a.x + w * (b.x - a.x), a.y + w * (b.y - a.y), a.yaw + w * dyaw)


def read_text_dump(scans: Path, odom: Path | None) -> Iterator[LogScan]:
    """Scans of a ``<name>_scans.txt[.gz]`` dump, with poses from ``<name>_odom.txt[.gz]``.

    Scan lines: stamp angle_min angle_increment range_min range_max n r_1 ... r_n.
    Odometry lines: stamp x y theta vx wz. Lines starting with # are comments.

    Raises:
        LogFormatError: a line that does not follow the format (file and line named).
    """
    stamps: list[float] = []
    poses: list[Pose2] = []
    if odom is not None:
        for number, line in _lines(odom):
            if line.startswith("#") or not line.strip():
                continue
            v = _numbers(line, odom, number)
            if len(v) < 4:
                raise LogFormatError(f"{odom}:{number}: expected stamp x y theta ...")
            _finite(v[:4], "stamp x y theta", odom, number)
            stamps.append(v[0])
            poses.append(Pose2(v[1], v[2], v[3]))
    odometry = OdometryTrack(stamps, poses)
    for number, line in _lines(scans):
        if line.startswith("#") or not line.strip():
            continue
        v = _numbers(line, scans, number)
        _finite(v[:6], "stamp angle_min angle_increment range_min range_max n", scans, number)
        if len(v) < 6 or len(v) != 6 + int(v[5]):
            raise LogFormatError(
                f"{scans}:{number}: expected stamp angle_min angle_increment range_min "
                f"range_max n and n ranges"
            )
        yield LogScan(v[0], v[1], v[2], v[3], v[4], np.array(v[6:]), odometry.at(v[0]))


def read_carmen(path: Path, *, range_max: float = 80.0) -> Iterator[LogScan]:
    """FLASER and ROBOTLASER1 scans of a CARMEN log (.clf, optionally gzipped).

    FLASER stores no field of view: 180 degrees over its beams is assumed, as CARMEN does.
    The odometry pose is the one stored in each laser line.
    """
    for number, line in _lines(path):
        words = line.split()
        if not words or words[0] not in ("FLASER", "ROBOTLASER1"):
            continue
        try:
            scan = _carmen_scan(words, range_max)
        except (ValueError, IndexError) as err:
            raise LogFormatError(f"{path}:{number}: malformed {words[0]} line: {err}") from err
        _finite(
            (scan.stamp, scan.angle_min, scan.angle_increment), "stamp and angles", path, number
        )
        assert scan.odom is not None
        _finite(scan.odom, "the odometry pose", path, number)
        yield scan


def _carmen_scan(words: list[str], range_max: float) -> LogScan:
    """One FLASER or ROBOTLASER1 line, split into words.

    Raises:
        ValueError, IndexError: the line does not have its fields.
    """
    if words[0] == "FLASER":
        n = int(words[1])
        if n < 2:
            raise ValueError(f"{n} beams; a scan needs at least 2")
        if len(words) < 2 + n + 7:
            raise ValueError(
                f"it says {n} beams, then has {len(words) - 2} values for them, the pose, the "
                "odometry and the time: it should have n + 7"
            )
        ranges = np.array(words[2 : 2 + n], dtype=np.float64)
        rest = [float(w) for w in words[2 + n : 2 + n + 7]]
        odom = Pose2(rest[3], rest[4], rest[5])
        return LogScan(rest[6], -math.pi / 2, math.pi / (n - 1), 0.0, range_max, ranges, odom)
    start, _fov, inc, max_range = (float(w) for w in words[2:6])
    n = int(words[8])
    ranges = np.array(words[9 : 9 + n], dtype=np.float64)
    if ranges.size != n:
        raise ValueError(f"it says {n} ranges and has {ranges.size}")
    m = int(words[9 + n])
    tail = [float(w) for w in words[10 + n + m : 10 + n + m + 14]]
    odom = Pose2(tail[3], tail[4], tail[5])
    stamp = float(words[10 + n + m + 11])
    return LogScan(stamp, start, inc, 0.0, max_range, ranges, odom)


def open_log(path: Path) -> Iterator[LogScan]:
    """Scans of the text log at ``path``, its format told by its name (ROS bags: ``bags``).

    ``*_scans.txt[.gz]`` reads with the ``*_odom.txt[.gz]`` beside it; ``*.clf[.gz]`` is CARMEN.

    Raises:
        LogFormatError: a format navd cannot read (the supported ones are named).
    """
    name = path.name
    if not path.exists():
        raise LogFormatError(f"{path}: no such file")
    if "_scans.txt" in name:
        odom = path.with_name(name.replace("_scans.txt", "_odom.txt"))
        return read_text_dump(path, odom if odom.exists() else None)
    if name.endswith((".clf", ".clf.gz", ".log", ".log.gz")):
        return read_carmen(path)
    raise LogFormatError(
        f"{path}: unknown log format; navd replays <name>_scans.txt[.gz] dumps (with "
        f"<name>_odom.txt[.gz] beside them), CARMEN .clf logs, ROS 1 .bag files and ROS 2 bag "
        f"folders"
    )


def count_scans(path: Path) -> int:
    """How many scans the text log at ``path`` holds (for a progress bar); 0 if unknown."""
    name = path.name
    if not path.exists() or path.is_dir():
        return 0
    lines = (line for _, line in _lines(path))
    if "_scans.txt" in name:
        return sum(1 for line in lines if line.strip() and not line.startswith("#"))
    if name.endswith((".clf", ".clf.gz", ".log", ".log.gz")):
        return sum(1 for line in lines if line.startswith(("FLASER", "ROBOTLASER1")))
    return 0
