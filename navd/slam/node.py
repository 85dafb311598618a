"""The SLAM module: scans in, scan-matched poses and map snapshots out.

Each LaserScan becomes a job in the ``scan_match`` worker slot (latest wins: when matching
falls behind, older scans are dropped and counted, never queued). The job matches the scan
onto the map around the pose predicted by wheel odometry (integrated here) or, without
wheels, by scan odometry (ICP onto a local map), inserts it at
keyframes, and returns a ``PoseMeasurement`` for the estimator and, at most once per
``MAP_PERIOD_S`` after the map changed, a ``MapUpdate`` (and once per ``MAP_PERIOD_S`` the
tracking counts, ``SlamTracking``). Maps are saved on request (a
control client's save_map), at shutdown if ``slam.save_on_shutdown``, and for a crash every
``slam.autosave_period_s`` while the map grows (``autosave``), with the pose graph
they were built from; ``slam.load_map`` starts from a saved map (mapping goes on with its
graph), and the first scan then finds the robot anywhere on it (global search); an initial
pose from a control client makes the next scan search around it (±1 m, ±30°). A robot lost
on its map is reported (``TrackingLost``) and searched for by the following scans until found
(``relocalization``). ``slam.updating_map`` can be switched at runtime (off: localize on the map
without changing it).
"""

from __future__ import annotations

import math
import threading
import time
from collections import deque
from pathlib import Path

import numpy as np

from navd.geometry import Pose2, laser_points
from navd.lifecycle import Module, ModuleContext
from navd.lifecycle.messages import (
    FindPoseRequest,
    InitialPose,
    LaserScan,
    LoadMapRequest,
    MapLoaded,
    MapSaved,
    MapUpdate,
    Message,
    PoseMeasurement,
    SaveMapRequest,
    SlamTracking,
    WheelOdometry,
)
from navd.slam.assembler import ScanAssembler
from navd.slam.autosave import AUTOSAVE_NAME, autosave_path, remove_autosave
from navd.slam.errors import MapFileError
from navd.slam.map_io import clean_leftovers, load_map_state, save_map, saved_files
from navd.slam.mapper import ScanMapper
from navd.slam.occupancy import OccupancyGrid
from navd.slam.odometry import ScanOdometry
from navd.slam.relocalization import GLOBAL, Relocalizer
from navd.slam.settings import SlamSettings
from navd.slam.warmup import warm_up

__all__ = ["SlamNode"]

AUTOSAVE_SHARE = 0.05  # the most of the time autosaves may take
MAX_WAITING_SAVES = 8  # save requests waiting at once; more are answered at once, refused

MAP_PERIOD_S = 1.0
_SLOT = "scan_match"


def _map_update(grid: OccupancyGrid, now: float) -> MapUpdate:
    """The map as published at ``now`` [s]: occupancy in percent, -1 unknown."""
    return MapUpdate(
        stamp=now,
        received=now,
        revision=grid.revision,
        resolution_m=grid.resolution,
        origin_x_m=grid.origin_x,
        origin_y_m=grid.origin_y,
        occupancy=grid.occupancy_percent(),
    )


class SlamNode(Module):
    """Runs the ScanMapper on live scans in a worker thread."""

    def __init__(self) -> None:
        super().__init__("slam")
        self._lock = threading.Lock()  # the mapper is used from worker threads
        self._odom = Pose2(0.0, 0.0, 0.0)
        self._odom_stamp: float | None = None
        self._has_odometry = False
        self._map_published_at = -math.inf
        self._map_revision = -1
        self._map_drawn = False  # the last job left a map (read without the lock)
        self._tracking_published_at = -math.inf
        self._scan_odometry: ScanOdometry | None = None
        self._saves: deque[tuple[str, str]] = deque()  # (name, folder) asked for, not yet done
        self._autosave_due = False  # the map grew: the next save job writes the autosave too
        self._autosaved = -1  # the map revision the autosave holds
        self._autosave_after = -math.inf  # [s, monotonic] not before (a large map's saves)

    async def on_configure(self, ctx: ModuleContext) -> None:
        self.ctx = ctx
        self._relocalizer = Relocalizer(ctx)
        self.settings = ctx.settings(SlamSettings.from_config, self._settings_changed)
        # What the mapper and scan odometry were built with: a change is applied between scans,
        # in a worker, so one scan never mixes a new mount with an old mapper.
        self._in_force = self.settings.value
        self._enabled = self._in_force.enabled  # needs a restart
        self.mapper = ScanMapper(self._in_force.mapper)
        lidars = self._in_force.mounts.lidars  # mounts need a restart
        self._assembler = ScanAssembler(lidars) if len(lidars) > 1 else None
        load = self._in_force.load_map  # needs a restart
        crashed = autosave_path(self._in_force.map_dir)
        if load is None and self._enabled and crashed.exists():
            load = str(crashed)  # the last run did not stop cleanly: go on from its map
            ctx.log.warning("map_recovered", path=load)
        if load is not None:
            try:
                saved = load_map_state(Path(load))
                self.mapper.load(saved.grid, saved.graph)
                self._map_drawn = not saved.grid.empty
            except MapFileError as err:  # the file the config names: a user's input
                raise MapFileError(f"slam.load_map: {err}") from err
            ctx.log.info(
                "map_loaded",
                path=load,
                cells=self.mapper.grid.shape,
                keyframes=len(self.mapper.keyframes),  # a saved graph goes on growing
            )
            self._relocalizer.ask(GLOBAL)  # where on this map? the first scan searches all of it
        ctx.subscribe(LaserScan, self._on_scan)
        ctx.subscribe(WheelOdometry, self._on_wheels)
        ctx.subscribe(InitialPose, self._on_initial_pose)
        ctx.subscribe(SaveMapRequest, self._on_save)
        ctx.subscribe(LoadMapRequest, self._on_load)
        ctx.subscribe(FindPoseRequest, self._on_find)

    async def on_activate(self) -> None:
        # Compile (or load from the cache) the kernels before the first scan; a scan job
        # arriving meanwhile waits in its worker on numba's compile lock, not on the loop.
        # With SLAM off no scan is matched: its kernels stay unloaded (12 MB here).
        if self._enabled:
            self.ctx.warm_up(warm_up, name="warm-up")
        self.ctx.submit("map_save", self._clean_map_dir)  # before any save, in their slot
        period = self._in_force.autosave_period_s  # (needs a restart)
        if self._enabled and period > 0.0:
            self.ctx.every(period, self._autosave_tick, name="map-autosave")

    async def on_deactivate(self) -> None:
        settings = self.settings.value  # map_dir, map_name, save_on_shutdown: read at use
        if settings.save_on_shutdown and self._map_drawn:
            self.ctx.publish(self._save(settings.map_name, settings.map_dir))
        remove_autosave(self._in_force.map_dir)  # a clean stop: nothing to recover

    def settings_in_use(self) -> tuple[object, ...]:
        odometry = self._scan_odometry
        return (
            self._in_force,
            self.mapper.settings,
            *(() if odometry is None else (odometry.settings,)),
        )

    def _settings_changed(self, _old: SlamSettings, new: SlamSettings) -> None:
        # The mapper is busy in a worker for up to a global search: never wait for it on the
        # event loop. The newest settings are applied by a job of their own (latest wins).
        # The job is handed them: it may start before the holder is swapped.
        self.ctx.submit("slam_settings", lambda: self._apply_settings(new))

    def _apply_settings(self, new: SlamSettings) -> None:
        """Worker: swap the mapper's settings for ``new``; rebuild scan odometry (it is built with
        its settings), letting the next scan start its motion prior afresh in the new
        odometry frame."""
        with self._lock:
            old = self._in_force
            if new.mapper != old.mapper:
                self.mapper.configure(new.mapper)
            if new.odometry != old.odometry and self._scan_odometry is not None:
                self._scan_odometry = ScanOdometry(new.odometry)
                if not self._has_odometry:
                    self.mapper.forget_odometry()
            self._in_force = new

    def _on_wheels(self, odom: WheelOdometry) -> None:
        """Dead-reckon the odometry pose: the motion prior of the next scan."""
        if self._odom_stamp is not None:
            dt = min(max(odom.stamp - self._odom_stamp, 0.0), 0.5)
            step = Pose2(odom.linear_mps * dt, 0.0, odom.angular_radps * dt)
            self._odom = self._odom.compose(step)
        self._odom_stamp = odom.stamp
        self._has_odometry = True

    def _on_scan(self, scan: LaserScan) -> None:
        if not self._enabled:
            return  # the lidar only shows obstacles (slam.enabled = false)
        odom = self._odom if self._has_odometry else None
        # With several lidars each has a slot of its own: a busy mapper must not keep
        # dropping one lidar's sweeps in favour of another's.
        slot = _SLOT if self._assembler is None else f"{_SLOT}:{scan.device_id}"
        self.ctx.submit(slot, lambda: self._match(scan, odom))

    def _match(self, scan: LaserScan, odom: Pose2 | None) -> tuple[Message, ...]:
        with self._lock:
            settings = self._in_force
            mapper = settings.mapper
            mount = settings.mounts.lidar(scan.device_id)
            points = laser_points(scan, mount, max_range_m=mapper.max_range_m)
            stamp = scan.stamp
            if self._assembler is not None:
                gathered = self._assembler.add(scan.device_id, stamp, points, odom)
                if gathered is None:
                    return ()  # the other lidars' sweeps of this round are still to come
                stamp, points, odom = gathered.stamp, gathered.points, gathered.odom
            if odom is None:
                # No wheel odometry: scan odometry is the motion prior.
                if self._scan_odometry is None:
                    self._scan_odometry = ScanOdometry(settings.odometry)
                odom = self._scan_odometry.register(points.hits)
            messages, searched = self._relocalizer.before(self.mapper, mapper, stamp, points, odom)
            if searched:  # lost: the scan went into the search, not the map
                return (*messages, *self._now_and_then())
            result = self.mapper.add(stamp, points, odom)
            now = self.ctx.clock.now()
            lost = self._relocalizer.after(self.mapper, mapper, stamp)
            if lost is not None:
                messages.append(lost)
            else:
                messages.insert(
                    0,
                    PoseMeasurement(
                        stamp=stamp,
                        received=now,
                        source="lidar",
                        x_m=result.pose.x,
                        y_m=result.pose.y,
                        yaw_rad=result.pose.yaw,
                        covariance=result.covariance,
                    ),
                )
            return (*messages, *self._now_and_then())

    def _now_and_then(self) -> tuple[Message, ...]:
        """Worker, under the lock: the map when it changed and the tracking counts, each at
        most once per MAP_PERIOD_S."""
        now = self.ctx.clock.now()
        messages: list[Message] = []
        grid = self.mapper.grid
        self._map_drawn = not grid.empty
        if grid.revision != self._map_revision and now - self._map_published_at >= MAP_PERIOD_S:
            self._map_revision = grid.revision
            self._map_published_at = now
            messages.append(_map_update(grid, now))
        if now - self._tracking_published_at >= MAP_PERIOD_S:
            self._tracking_published_at = now
            counts = self.mapper.tracking_counts()
            messages.append(SlamTracking(stamp=now, received=now, counts=counts))
        return tuple(messages)

    def _on_initial_pose(self, pose: InitialPose) -> None:
        # A person's guess: the next scan searches around it (±1 m, ±30°) on the map. (The
        # seeds this module sends the estimate come back here too: they are no guess.)
        if not self._relocalizer.sent(pose):
            self._relocalizer.ask(Pose2(pose.x_m, pose.y_m, pose.yaw_rad))

    def _on_save(self, request: SaveMapRequest) -> None:
        settings = self.settings.value
        name = request.name or settings.map_name
        if len(self._saves) >= MAX_WAITING_SAVES:
            reason = f"{MAX_WAITING_SAVES} saves are waiting already; ask again when one is done"
            self.ctx.publish(self._saved(name, reason=reason))
            return
        self._saves.append((name, request.folder or settings.map_dir))
        # the slot keeps one waiting job, and each job saves every request waiting
        self.ctx.submit("map_save", self._save_waiting)

    def _on_find(self, _request: FindPoseRequest) -> None:
        # The next scan searches the whole map; the estimate is re-seeded with what it finds.
        # Not the grid itself (a job may be redrawing it under the lock): whether the last
        # job left a map, as it noted.
        if not self._map_drawn:
            self.ctx.log.warning("pose_find_ignored", reason="no map yet: nothing to search")
            return
        self._relocalizer.ask(GLOBAL, reseed=True)  # (its own lock: a search may hold the mapper's)

    def _on_load(self, request: LoadMapRequest) -> None:
        folder = request.folder or self.settings.value.map_dir
        self.ctx.submit("map_load", lambda: self._load(request.name, folder))

    def _load(self, name: str, folder: str) -> tuple[Message, ...]:
        """Worker: read ``folder/name.yaml`` and start over on it: a fresh mapper on the
        loaded grid, the robot searched for on all of it at the next scan. A file that cannot
        be used keeps the map in use, with the reason."""
        path = Path(folder) / f"{name}.yaml"
        now = self.ctx.clock.now()
        try:
            saved = load_map_state(path)  # outside the lock: reading a large map takes a while
        except MapFileError as err:
            self.ctx.log.warning("map_not_loaded", name=name, reason=str(err))
            return (MapLoaded(stamp=now, received=now, name=name, reason=str(err)),)
        with self._lock:
            self.mapper = ScanMapper(self._in_force.mapper)
            self.mapper.load(saved.grid, saved.graph)
            grid = saved.grid
            self._map_drawn = not grid.empty
            # the estimate, in the old map's frame, starts again too
            self._relocalizer.ask(GLOBAL, reseed=True)
            self._map_revision = grid.revision
            self._map_published_at = now
            # under the lock: the next scan job draws into this very grid
            update = _map_update(grid, now)
        self.ctx.log.info(
            "map_loaded",
            path=str(path),
            cells=grid.shape,
            keyframes=0 if saved.graph is None else len(saved.graph.keyframes),
        )
        loaded = MapLoaded(stamp=now, received=now, name=name, path=str(path))
        return (loaded, update)

    def _autosave_tick(self, _now: float) -> None:
        """Event loop: the map grew since the autosave was written: a save job writes it."""
        grew = self._map_drawn and self.mapper.grid.revision != self._autosaved
        if grew and time.monotonic() >= self._autosave_after:
            self._autosave_due = True
            self.ctx.submit("map_save", self._save_waiting)

    def _save_waiting(self) -> tuple[MapSaved, ...]:
        """Worker: every save asked for since the last job, each answered; the autosave if
        due (not answered: nobody asked)."""
        answers: list[MapSaved] = []
        while self._saves:
            name, folder = self._saves.popleft()
            answers.append(self._save(name, folder))
        if self._autosave_due:
            self._autosave_due = False
            self._autosaved = self.mapper.grid.revision  # (a later change is saved next time)
            began = time.monotonic()
            self._save(AUTOSAVE_NAME, self._in_force.map_dir, quiet=True)
            # a map so large its save takes long is saved less often: at most AUTOSAVE_SHARE
            # of the time goes to it (and of an SD card's writes)
            self._autosave_after = began + (time.monotonic() - began) / AUTOSAVE_SHARE
        return tuple(answers)

    def _save(self, name: str, folder: str, *, quiet: bool = False) -> MapSaved:
        """Worker (or shutdown): write the map; a disk that refuses is reported, not raised
        (it is not a fault of the mapper, and must never stop the robot). ``quiet``: the
        success is logged at debug (the autosave, every few seconds)."""
        with self._lock:
            grid = self.mapper.grid
            if grid.empty:
                self.ctx.log.warning("map_not_saved", reason="the map is empty", name=name)
                return self._saved(name, reason="the map is empty")
            snapshot = grid.copy()
            graph = self.mapper.graph()
            poses = np.array([tuple(k.pose) for k in graph.keyframes]).reshape(-1, 3)
        try:
            path = save_map(snapshot, Path(folder), name, keyframe_poses=poses, graph=graph)
        except (MapFileError, OSError) as err:
            self.ctx.log.error("map_not_saved", name=name, folder=folder, reason=str(err))
            return self._saved(name, reason=f"cannot write to {folder}: {err}")
        (self.ctx.log.debug if quiet else self.ctx.log.info)("map_saved", path=str(path))
        return self._saved(name, path=str(path), files=tuple(str(f) for f in saved_files(path)))

    def _clean_map_dir(self) -> None:
        """Worker: remove what saves cut short by a crash or a power cut left behind."""
        folder = Path(self.settings.value.map_dir)
        removed = clean_leftovers(folder)
        if removed:
            self.ctx.log.info(
                "map_dir_cleaned",
                folder=str(folder),
                removed=len(removed),
                first=[p.name for p in removed[:10]],
            )

    def _saved(
        self, name: str, *, path: str = "", reason: str = "", files: tuple[str, ...] = ()
    ) -> MapSaved:
        now = self.ctx.clock.now()
        return MapSaved(stamp=now, received=now, name=name, path=path, reason=reason, files=files)
