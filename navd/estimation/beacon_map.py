"""Beacon places learnt from bearings (and ranges) taken as the robot moves: a Kalman filter
per beacon, as seed 004 does it.

Each beacon's place is a 2-state EKF. A bearing alone cannot place a beacon, so its first
bearings are kept as rays (where the robot stood, which way it looked) until they cross at
a useful angle; the place where they cross best (least squares on the bearings, solved by
Gauss-Newton from the rays' linear crossing) starts the filter, with the covariance the
rays give it, once that is tight enough (``MAX_START_STD_M``). An EKF from a poor first
guess can lock onto a wrong place (the bearings' nonlinearity); if it then refuses
``MAX_REFUSED_RUN`` observations in a row, the beacon is learnt again from fresh rays. A range
together with the bearing places the beacon at once. The robot's own uncertainty at the time
of the observation is added to the measurement's (its Jacobian with respect to the robot's
x, y and yaw), so a beacon learnt from a poor pose is uncertain too, and an observation
farther than ``gate_chi2`` from the filter's prediction is refused (a reflection, another
beacon answering under the same id).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from navd.config import BeaconPlaceConfig
from navd.geometry import wrap_angle
from navd.lifecycle.messages import BeaconPlace

__all__ = ["BeaconMap", "LearntBeacon", "RobotPose"]

FloatArray = npt.NDArray[np.float64]

# Bearing rays kept per beacon while waiting for two to cross.
MAX_RAYS = 50
# [rad] the rays' directions must spread at least this much to cross usefully.
MIN_CROSSING_RAD = math.radians(10.0)
# [m] beacons are not placed farther than this from the rays' origins (near-parallel rays).
MAX_PLACE_M = 200.0
# [m^2] a beacon's covariance before anything is known of it.
START_VARIANCE_M2 = 25.0
# [m] the rays' crossing starts the filter once its worst 1-sigma is below this.
MAX_START_STD_M = 1.0
# Observations refused in a row that make a placed beacon be learnt again.
MAX_REFUSED_RUN = 20


@dataclass(frozen=True, slots=True)
class RobotPose:
    """The robot's pose when it observed, and its uncertainty.

    Attributes:
        x_m, y_m, yaw_rad: [m, m, rad] the pose in the map frame.
        covariance: 3 x 3 over (x, y, yaw).
    """

    x_m: float
    y_m: float
    yaw_rad: float
    covariance: FloatArray


@dataclass
class LearntBeacon:
    """One beacon's filter: its place (None until placed), covariance, and the rays kept
    until then.

    Attributes:
        mean: [m] (x, y), None until placed.
        covariance: 2 x 2 [m^2].
        rays: (robot pose, bearing [rad], bearing variance [rad^2]) waiting for a crossing.
        observations: observations taken into the place (or kept as rays).
        refused: observations refused by the gate; refused_run: of them, in a row.
    """

    mean: FloatArray | None = None
    covariance: FloatArray = field(default_factory=lambda: np.eye(2) * START_VARIANCE_M2)
    rays: list[tuple[RobotPose, float, float]] = field(default_factory=list)
    observations: int = 0
    refused: int = 0
    refused_run: int = 0

    @property
    def std_m(self) -> float:
        """[m] 1-sigma of the place along its worst direction (inf before placed)."""
        if self.mean is None:
            return math.inf
        return math.sqrt(max(float(np.linalg.eigvalsh(self.covariance)[-1]), 0.0))


class BeaconMap:
    """Places of beacons not given in the config, learnt from their observations.

    Args:
        gate_chi2: observations whose squared Mahalanobis distance exceeds this are refused.
    """

    def __init__(self, gate_chi2: float) -> None:
        self.gate_chi2 = gate_chi2
        self.beacons: dict[str, LearntBeacon] = {}
        self.revision = 0  # grows whenever a place changes

    def observe(
        self,
        beacon_id: str,
        pose: RobotPose,
        *,
        range_m: float = math.nan,
        range_std_m: float = 0.1,
        bearing_rad: float = math.nan,
        bearing_std_rad: float = 0.05,
    ) -> bool:
        """Take a range and/or bearing [m, rad] to ``beacon_id`` seen from ``pose``; True if
        it changed the beacon's place (False: kept as a ray, refused, or a range alone to a
        beacon not yet placed)."""
        beacon = self.beacons.setdefault(beacon_id, LearntBeacon())
        has_range, has_bearing = math.isfinite(range_m), math.isfinite(bearing_rad)
        if beacon.mean is None:
            if has_range and has_bearing:
                self._place_at(
                    beacon,
                    pose,
                    range_m=range_m,
                    range_std_m=range_std_m,
                    bearing_rad=bearing_rad,
                    bearing_std_rad=bearing_std_rad,
                )
                return True
            if not has_bearing:
                return False  # a range alone says nothing of the direction
            beacon.observations += 1
            beacon.rays.append((pose, bearing_rad, bearing_std_rad**2))
            del beacon.rays[:-MAX_RAYS]
            return self._cross(beacon)
        changed = False
        if has_bearing:
            changed |= self._update(beacon, pose, "bearing", bearing_rad, bearing_std_rad**2)
        if has_range:
            changed |= self._update(beacon, pose, "range", range_m, range_std_m**2)
        return changed

    # --- placing a beacon ------------------------------------------------------------------

    def _place_at(
        self,
        beacon: LearntBeacon,
        pose: RobotPose,
        *,
        range_m: float,
        range_std_m: float,
        bearing_rad: float,
        bearing_std_rad: float,
    ) -> None:
        """Place a beacon from one range and bearing, its covariance through the Jacobian of
        the place with respect to the robot's pose and the measurement."""
        heading = pose.yaw_rad + bearing_rad
        c, s = math.cos(heading), math.sin(heading)
        beacon.mean = np.array([pose.x_m + range_m * c, pose.y_m + range_m * s])
        # d place / d (x, y, yaw, range, bearing)
        jacobian = np.array(
            [[1.0, 0.0, -range_m * s, c, -range_m * s], [0.0, 1.0, range_m * c, s, range_m * c]]
        )
        noise = np.zeros((5, 5))
        noise[:3, :3] = pose.covariance
        noise[3, 3], noise[4, 4] = range_std_m**2, bearing_std_rad**2
        beacon.covariance = jacobian @ noise @ jacobian.T
        beacon.observations += 1
        beacon.rays.clear()
        self.revision += 1

    def _cross(self, beacon: LearntBeacon) -> bool:
        """Place the beacon where its rays cross best, once they spread enough and the
        crossing is tight enough."""
        rays = beacon.rays
        directions = np.array([wrap_angle(p.yaw_rad + b) for p, b, _ in rays])
        spread = np.abs(np.angle(np.exp(1j * (directions[:, None] - directions[None, :]))))
        if float(spread.max()) < MIN_CROSSING_RAD:
            return False
        # each ray: its normal n, n . (place - origin) = 0
        normals = np.column_stack([-np.sin(directions), np.cos(directions)])
        origins = np.array([[p.x_m, p.y_m] for p, _, _ in rays])
        a = normals.T @ normals
        if np.linalg.cond(a) > 1e6:
            return False
        place = np.linalg.solve(a, normals.T @ np.einsum("ij,ij->i", normals, origins))
        solved = _best_crossing(rays, place)
        if solved is None:
            return False
        place, covariance = solved
        forward = np.column_stack([np.cos(directions), np.sin(directions)])
        ahead = np.einsum("ij,ij->i", place - origins, forward)
        if (ahead <= 0.0).any() or float(np.hypot(*(place - origins).T).max()) > MAX_PLACE_M:
            return False  # behind a ray, or rays nearly parallel: not crossed yet
        if float(np.linalg.eigvalsh(covariance)[-1]) > MAX_START_STD_M**2:
            return False  # crossed, too loosely yet: more rays
        beacon.mean, beacon.covariance = place, _no_surer_than(covariance, _pose_of_last(rays))
        beacon.rays = []
        beacon.refused_run = 0
        self.revision += 1
        return True

    # --- refining a place ------------------------------------------------------------------

    def _update(
        self,
        beacon: LearntBeacon,
        pose: RobotPose,
        kind: str,
        value: float,
        variance: float,
        *,
        count: bool = True,
    ) -> bool:
        """One EKF update of the beacon's place with a bearing or a range; False if gated."""
        assert beacon.mean is not None
        dx, dy = beacon.mean[0] - pose.x_m, beacon.mean[1] - pose.y_m
        r2 = max(dx * dx + dy * dy, 1e-6)
        if kind == "bearing":
            residual = wrap_angle(value - (math.atan2(dy, dx) - pose.yaw_rad))
            h_beacon = np.array([-dy / r2, dx / r2])
            h_robot = np.array([dy / r2, -dx / r2, -1.0])
        else:
            r = math.sqrt(r2)
            residual = value - r
            h_beacon = np.array([dx / r, dy / r])
            h_robot = np.array([-dx / r, -dy / r, 0.0])
        noise = variance + float(h_robot @ pose.covariance @ h_robot)
        s = float(h_beacon @ beacon.covariance @ h_beacon) + noise
        if count:
            beacon.observations += 1
        if residual * residual / s > self.gate_chi2:
            beacon.refused += 1
            beacon.refused_run += 1
            if beacon.refused_run >= MAX_REFUSED_RUN:
                # locked onto a wrong place: learn it again from fresh rays
                beacon.mean, beacon.covariance = None, np.eye(2) * START_VARIANCE_M2
                beacon.refused_run = 0
                self.revision += 1
            return False
        beacon.refused_run = 0
        gain = beacon.covariance @ h_beacon / s
        beacon.mean = beacon.mean + gain * residual
        joseph = np.eye(2) - np.outer(gain, h_beacon)  # Joseph's form: stays symmetric
        covariance = joseph @ beacon.covariance @ joseph.T + np.outer(gain, gain) * noise
        beacon.covariance = _no_surer_than(covariance, pose)
        self.revision += 1
        return True

    def places(self, known: Mapping[str, BeaconPlaceConfig]) -> tuple[BeaconPlace, ...]:
        """Every beacon with a place: the ``known`` ones (the config's), then those learnt so
        far."""
        places = [BeaconPlace(b, p.x_m, p.y_m, 0.0, False, 0) for b, p in known.items()]
        for beacon_id, learnt in self.beacons.items():
            if learnt.mean is not None and beacon_id not in known:
                x, y = (float(v) for v in learnt.mean)
                places.append(BeaconPlace(beacon_id, x, y, learnt.std_m, True, learnt.observations))
        return tuple(places)


def _best_crossing(
    rays: list[tuple[RobotPose, float, float]], start: FloatArray
) -> tuple[FloatArray, FloatArray] | None:
    """The place whose bearings from the rays' origins best fit theirs (weighted least
    squares, each ray's noise with its pose's added), by Gauss-Newton from ``start``; and
    its covariance. None if it does not settle."""
    place = start.astype(np.float64)
    normal = np.eye(2)
    for _ in range(10):
        rows, residuals, weights = [], [], []
        for pose, bearing, variance in rays:
            dx, dy = place[0] - pose.x_m, place[1] - pose.y_m
            r2 = max(dx * dx + dy * dy, 1e-6)
            h_robot = np.array([dy / r2, -dx / r2, -1.0])
            rows.append((-dy / r2, dx / r2))
            residuals.append(wrap_angle(bearing - (math.atan2(dy, dx) - pose.yaw_rad)))
            weights.append(1.0 / (variance + float(h_robot @ pose.covariance @ h_robot)))
        jacobian, w = np.array(rows), np.array(weights)
        normal = jacobian.T @ (w[:, None] * jacobian)
        if np.linalg.cond(normal) > 1e12:
            return None
        step = np.linalg.solve(normal, jacobian.T @ (w * np.array(residuals)))
        place = place + step
        if float(np.hypot(*step)) < 1e-4:
            return place, np.linalg.inv(normal)
    return None


def _pose_of_last(rays: list[tuple[RobotPose, float, float]]) -> RobotPose:
    """The robot's pose at the newest of ``rays``."""
    return rays[-1][0]


def _no_surer_than(covariance: FloatArray, pose: RobotPose) -> FloatArray:
    """``covariance`` with no direction surer than the robot's position at ``pose``: the
    bearings are taken from poses whose errors are correlated (they drift together), which
    a filter treating each bearing alone cannot see, so the robot's own uncertainty is the
    floor of the beacon's."""
    floor = float(np.linalg.eigvalsh(pose.covariance[:2, :2])[-1])
    values, vectors = np.linalg.eigh(covariance)
    if values[0] >= floor:
        return covariance
    floored: FloatArray = (vectors * np.maximum(values, floor)) @ vectors.T
    return floored
