"""Finding the robot on its map: the searches a person or a loaded map asks for, and the
search for a robot lost on its map (``lost_search``), as the SLAM module runs them.

A search asked for runs at the next scan: around a given pose (±1 m, ±30°), or over the
whole map (``GLOBAL``: a map just loaded, ``navd pose find``). On a map not yet begun, a given
pose is where the map starts. When the mapper calls the robot lost, the module says so
(``TrackingLost``) and each scan goes into the lost search instead of the map until it finds
the robot; then, as after a person's ``pose find``, the estimate is re-seeded from the pose
found (an ``InitialPose`` this module sent, which comes back to it and is no guess to act on).
"""

from __future__ import annotations

import threading

import numpy as np
import numpy.typing as npt

from navd.geometry import Pose2, ScanPoints
from navd.lifecycle import ModuleContext
from navd.lifecycle.messages import InitialPose, Message, PoseFound, TrackingLost
from navd.slam.global_search import relocalize
from navd.slam.lost_search import LostSearch, fit_on_map
from navd.slam.mapper import ScanMapper
from navd.slam.settings import MapperSettings
from navd.slam.voxel import voxel_downsample

__all__ = ["GLOBAL", "Relocalizer"]

FloatArray = npt.NDArray[np.float64]
GLOBAL = "global"
# How sure the estimate is told to be of a pose a search found [m], [rad].
RESEED_STD_M = 0.2
RESEED_STD_RAD = 0.1


class Relocalizer:
    """What the next scan is to search for, and the search for a lost robot.

    ``ask`` may come from the event loop: it takes only a small lock of its own, never the
    SLAM module's, which a search holds for up to a second or two. The rest runs in the
    SLAM worker under the module's lock.

    Args:
        ctx: the SLAM module's context (clock and log).
    """

    def __init__(self, ctx: ModuleContext) -> None:
        self.ctx = ctx
        self._asked = threading.Lock()  # the two fields below
        # the next scan finds the robot on the map: anywhere (GLOBAL), near a pose, or no
        self.relocate: Pose2 | str | None = None
        self.reseed = False  # the next search's pose re-seeds the estimate
        self.lost: LostSearch | None = None  # searching for the robot lost on the map
        self._seeded: InitialPose | None = None  # the last seed sent to the estimate

    def ask(self, where: Pose2 | str, *, reseed: bool = False) -> None:
        """Search at the next scan around ``where`` (a pose), or on the whole map
        (``GLOBAL``); ``reseed``: the estimate starts again from what it finds."""
        with self._asked:
            self.relocate = where
            self.reseed = reseed

    def sent(self, pose: InitialPose) -> bool:
        """True if ``pose`` is the seed this module sent the estimate last."""
        return pose == self._seeded

    def before(
        self,
        mapper: ScanMapper,
        settings: MapperSettings,
        stamp: float,
        points: ScanPoints,
        odom: Pose2,
    ) -> tuple[list[Message], bool]:
        """Worker: the searches due at this scan, before the mapper takes it: what they
        found, and True if the scan went into the lost search (the mapper must not take it)."""
        with self._asked:
            where, reseed = self.relocate, self.reseed
            if where is not None and (isinstance(where, Pose2) or not mapper.grid.empty):
                self.relocate, self.reseed = None, False  # taken (a whole-map search waits)
        if isinstance(where, Pose2) and mapper.grid.empty:
            # No map yet: the given pose is where the new map starts.
            mapper.set_pose(where)
            mapper.forget_odometry()
        elif where is not None and not mapper.grid.empty:
            found = voxel_downsample(points.hits, settings.voxel_size_m)
            asked = self._relocalize(mapper, settings, stamp, found, where=where, reseed=reseed)
            return asked, False
        if self.lost is not None:
            seen = voxel_downsample(points.hits, settings.voxel_size_m)
            return self._search(mapper, stamp, seen, odom), True
        return [], False

    def after(self, mapper: ScanMapper, settings: MapperSettings, stamp: float) -> Message | None:
        """Worker: after the mapper took a scan, ``TrackingLost`` if it has just lost the
        robot (the search starts with the next scan)."""
        if not mapper.lost or self.lost is not None:
            return None
        last_good = mapper.last_good or mapper.pose or Pose2(0.0, 0.0, 0.0)
        self.lost = LostSearch(settings, last_good)
        scans = settings.lost_after_scans
        reason = (
            f"scan matching lost the robot: {scans} scans in a row did not fit the map where it "
            "should be; it stays stopped while the map is searched for it"
        )
        self.ctx.log.warning(
            "lost_on_map", last_good=tuple(round(v, 3) for v in last_good), scans=scans
        )
        return self._tracking(stamp, lost=True, reason=reason)

    def _relocalize(
        self,
        mapper: ScanMapper,
        settings: MapperSettings,
        stamp: float,
        points: FloatArray,
        *,
        where: Pose2 | str,
        reseed: bool,
    ) -> list[Message]:
        """The search asked for. A robot lost is then lost no more if what it found fits
        the map as a lost robot's pose must; otherwise it stays lost and held, and its
        search goes on, around the pose given if one was."""
        guess = where if isinstance(where, Pose2) else None
        found = relocalize(mapper.grid, points, guess=guess, reach_m=settings.max_range_m)
        if self.lost is not None and fit_on_map(mapper.grid, points, found, settings) is None:
            self.ctx.log.warning(
                "pose_not_taken",
                reason="the robot is lost and the search asked for found no pose that fits "
                "the map clearly; it stays stopped and searches on",
                guess=None if guess is None else tuple(round(v, 3) for v in guess),
            )
            if guess is not None:
                self.lost = LostSearch(settings, guess)
            return []
        self.ctx.log.info(
            "relocalized",
            x=round(found.pose.x, 3),
            y=round(found.pose.y, 3),
            yaw=round(found.pose.yaw, 3),
            score=round(found.score, 3),
            guess=None if guess is None else tuple(round(v, 3) for v in guess),
        )
        mapper.set_pose(found.pose)
        mapper.forget_odometry()
        pose_found = self._found(stamp, found.pose, found.score, whole_map=guess is None)
        messages: list[Message] = [pose_found]
        if reseed:  # asked for by a person: the estimate starts again from it
            messages.append(self._seed(stamp, pose_found))
        if self.lost is not None:
            self.lost = None
            messages.append(self._tracking(stamp, lost=False, reason="found by a search asked for"))
        return messages

    def _search(
        self, mapper: ScanMapper, stamp: float, points: FloatArray, odom: Pose2
    ) -> list[Message]:
        """One search for the lost robot; once it is found, the mapper and the estimate
        start again from there."""
        assert self.lost is not None
        found = self.lost.step(mapper.grid, points, odom)
        if found is None:
            return []
        self.lost = None
        mapper.set_pose(found.pose)
        mapper.forget_odometry()
        where = "the whole map" if found.window_m == 0.0 else f"{found.window_m:g} m"
        self.ctx.log.info(
            "found_on_map",
            x=round(found.pose.x, 3),
            y=round(found.pose.y, 3),
            yaw=round(found.pose.yaw, 3),
            fit=round(found.fit, 3),
            searches=found.searches,
            window=where,
        )
        reason = f"found again by {found.searches} searches within {where} (fit {found.fit:.2f})"
        pose_found = self._found(stamp, found.pose, found.fit, whole_map=found.window_m == 0.0)
        return [
            pose_found,
            self._seed(stamp, pose_found),
            self._tracking(stamp, lost=False, reason=reason),
        ]

    def _found(self, stamp: float, pose: Pose2, score: float, *, whole_map: bool) -> PoseFound:
        return PoseFound(
            stamp=stamp,  # the scan's: where the robot was when it was taken
            received=self.ctx.clock.now(),
            x_m=pose.x,
            y_m=pose.y,
            yaw_rad=pose.yaw,
            score=score,
            whole_map=whole_map,
        )

    def _seed(self, stamp: float, found: PoseFound) -> InitialPose:
        self._seeded = InitialPose(
            stamp=stamp,
            received=found.received,
            x_m=found.x_m,
            y_m=found.y_m,
            yaw_rad=found.yaw_rad,
            std_xy_m=RESEED_STD_M,
            std_yaw_rad=RESEED_STD_RAD,
        )
        return self._seeded

    def _tracking(self, stamp: float, *, lost: bool, reason: str) -> TrackingLost:
        now = self.ctx.clock.now()
        return TrackingLost(stamp=stamp, received=now, lost=lost, reason=reason)
