"""The group's way on a map: the centre's route around walls, and at each step the formation
asked for where it fits, a column where it does not (doors, corridors).

The centre's route is planned as one robot plans its own (A* on the map inflated by a robot's
radius and margin, smoothed). Its length is cut into steps; at each step the formation is laid
around the centre, facing along the route. It fits when every place is ``FIT_SLACK_M`` clearer
than a robot needs and can be seen from the centre (no robot stands behind a wall). A step
keeps the formation asked for only when it fits all along the route from the step before to
the step after (tried every ``FIT_EVERY_M``): the group forms a column a step before a narrow
passage and spreads out a step after it (the form-up place and the goal need only fit
themselves). In a column the robots follow the route itself, ``spacing_m`` of route apart,
so they turn through doors one after another, in steps of half the spacing
(``COLUMN_STEP_SHARE``). A column that would stand off its route's ends and in a wall moves
along until all of it is on the route, except at the goal, where the group's centre must be.
Without a map the route is the straight line and the formation is kept throughout.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from scipy.optimize import linear_sum_assignment

from navd.fleetctl.errors import GroupGoalError
from navd.fleetctl.formation import Formation, assign, places, slots
from navd.fleetctl.group_map import GroupMap

__all__ = ["GroupRoute", "lay_out"]

FloatArray = npt.NDArray[np.float64]
# [m] a formation's place must be this much clearer of walls than a robot needs: robots are
# never exactly on their places, and one squeezed against a wall slows the whole group
FIT_SLACK_M = 0.15
# a column goes on this share of its spacing at a time: each robot's next place is then clear
# of the robot ahead of it, which has not left it yet (robots of 0.4 m and 1.5 m spacing:
# 0.75 m apart, with 0.55 m between the place and the body ahead; with a whole spacing the
# next robot could not even plan to its place until the one ahead had gone half a metre)
COLUMN_STEP_SHARE = 0.5
# [m] the formation is tried along the route this often (a door between two steps is seen)
FIT_EVERY_M = 0.2
# [m] a route shorter than this (the goal where the group's centre is) is laid this long
# along the goal's heading, so the formation has a direction
MIN_ROUTE_M = 1e-3
# [m] the route's heading at a point is that of the chord this long around it (a smoothed
# route turns at corners; the formation should not flip there)
HEADING_CHORD_M = 1.0


class _Polyline:
    """Points along a route by distance, extended straight past both ends."""

    def __init__(self, points_m: FloatArray) -> None:
        keep = np.concatenate([[True], np.hypot(*np.diff(points_m, axis=0).T) > 1e-9])
        self.points = points_m[keep]
        steps = np.hypot(*np.diff(self.points, axis=0).T)
        self.along = np.concatenate([[0.0], np.cumsum(steps)])
        self.length_m = float(self.along[-1])

    def at(self, s_m: float) -> FloatArray:
        """[m] the point ``s_m`` along (before the start or past the end: straight on)."""
        p: FloatArray = self.points
        if p.shape[0] == 1:
            return np.array(p[0], dtype=np.float64)
        if s_m < 0.0:
            d = (p[1] - p[0]) / np.hypot(*(p[1] - p[0]))
            return np.array(p[0] + s_m * d, dtype=np.float64)
        if s_m > self.length_m:
            d = (p[-1] - p[-2]) / np.hypot(*(p[-1] - p[-2]))
            return np.array(p[-1] + (s_m - self.length_m) * d, dtype=np.float64)
        return np.array([np.interp(s_m, self.along, p[:, 0]), np.interp(s_m, self.along, p[:, 1])])

    def heading(self, s_m: float) -> float:
        """[rad] the route's heading at ``s_m``: its chord of HEADING_CHORD_M around it."""
        half = 0.5 * HEADING_CHORD_M
        a, b = self.at(s_m - half), self.at(s_m + half)
        return math.atan2(b[1] - a[1], b[0] - a[0])


@dataclass(frozen=True)
class GroupRoute:
    """Each robot's place and heading at each step, and the group's shape there.

    Attributes:
        places_m: [m] robots x steps x 2: robot i's place at step k (0: where it forms up).
        headings_rad: [rad] robots x steps: which way it faces there.
        shapes: the formation at each step (the one asked for, or "column").
        route_m: [m] N x 2: the centre's route.
        stations_m: [m] robots x steps: how far along the route robot i's place at step k
            is when the group is in a column there (NaN where it is not).
    """

    places_m: FloatArray
    headings_rad: FloatArray
    shapes: tuple[Formation, ...]
    route_m: FloatArray
    stations_m: FloatArray

    def target_m(self, k: int, fraction: float) -> FloatArray:
        """[m] robots x 2: where each robot should be when the group has come ``fraction``
        (0..1) of step k (from the places of step k - 1 to those of step k): along the route
        for a robot in a column at both ends of the step (it turns through doors), straight
        between its two places otherwise."""
        if k <= 0:
            return self.places_m[:, 0].copy()
        a, b = self.places_m[:, k - 1], self.places_m[:, k]
        out = a + fraction * (b - a)
        line = _Polyline(self.route_m)
        for i in range(out.shape[0]):
            s0, s1 = self.stations_m[i, k - 1], self.stations_m[i, k]
            if math.isfinite(s0) and math.isfinite(s1):
                out[i] = line.at(s0 + fraction * (s1 - s0))
        return out

    def shape_summary(self) -> str:
        """The shapes in order, runs counted: "triangle x2, column x4, triangle x3"."""
        runs = itertools.groupby(self.shapes)
        return ", ".join(f"{shape} x{sum(1 for _ in run)}" for shape, run in runs)


def lay_out(
    robots_xy_m: FloatArray,
    goal_xy_m: tuple[float, float],
    *,
    goal_heading_rad: float | None,
    formation: Formation,
    spacing_m: float,
    step_m: float,
    group_map: GroupMap | None = None,
) -> GroupRoute:
    """The group's way (see the module docstring) from where the robots stand.

    Raises:
        GroupGoalError: no route for the centre, or the group does not fit somewhere even in a
            column (where, named).
    """
    count = robots_xy_m.shape[0]
    start = robots_xy_m.mean(axis=0)
    route = _centre_route(start, goal_xy_m, goal_heading_rad, group_map)
    line = _Polyline(route)
    steps = max(math.ceil(line.length_m / step_m), 1)
    stations = [k * line.length_m / steps for k in range(steps + 1)]
    end_heading = line.heading(line.length_m) if goal_heading_rad is None else goal_heading_rad
    wide = slots(formation, count, spacing_m)
    column = slots("column", count, spacing_m)
    layer = _Layer(line, group_map, wide, column, end_heading, explicit=goal_heading_rad)
    # the formation is kept at a step where it fits there and, between the ends, all along
    # the route from the step before to the step after
    keep = [
        formation != "column"
        and layer.lay(s, wide=True, at_goal=k == steps) is not None
        and (k in (0, steps) or layer.fits_along(stations[k - 1], stations[k + 1]))
        for k, s in enumerate(stations)
    ]
    if keep[0] and not keep[1]:
        keep[0] = False  # the group forms up in the shape it sets off in
    plan = _shape_plan(stations, keep, layer, COLUMN_STEP_SHARE * spacing_m)
    shapes: list[Formation] = []
    step_places: list[FloatArray] = []
    step_headings: list[FloatArray] = []
    step_stations: list[FloatArray] = []
    for s, wide_here in plan:
        laid_here = layer.lay(s, wide=wide_here, at_goal=s == stations[-1])
        if laid_here is None:
            x, y = line.at(s)
            raise GroupGoalError(
                f"the group does not fit around ({x:.2f}, {y:.2f}) m, not even in a column "
                f"{spacing_m:g} m apart: try a smaller spacing or another goal"
            )
        on_route = np.isfinite(laid_here[2]).all()
        if on_route and shapes and shapes[-1] == "column" and np.isfinite(step_stations[-1]).all():
            # a column moved on along its route at its start never steps back, and a step
            # that would not move it is left out
            laid_here = layer.onward(laid_here, step_stations[-1], at_goal=s == stations[-1])
            if laid_here is None:
                continue
        shapes.append(formation if wide_here else "column")
        step_places.append(laid_here[0])
        step_headings.append(laid_here[1])
        step_stations.append(laid_here[2])
    slot = assign(robots_xy_m, step_places[0])
    places_m = np.empty((count, len(shapes), 2))
    headings_rad = np.empty((count, len(shapes)))
    stations_m = np.empty((count, len(shapes)))
    for k in range(len(shapes)):
        if k > 0 and shapes[k] != shapes[k - 1]:
            slot = _regroup(places_m[:, k - 1], step_places[k])
        places_m[:, k] = step_places[k][slot]
        headings_rad[:, k] = step_headings[k][slot]
        stations_m[:, k] = step_stations[k][slot]
    return GroupRoute(places_m, headings_rad, tuple(shapes), route, stations_m)


class _Layer:
    """The group's places at a station along the route, in the formation or in a column."""

    def __init__(
        self,
        line: _Polyline,
        group_map: GroupMap | None,
        wide: FloatArray,
        column: FloatArray,
        goal_heading_rad: float,
        *,
        explicit: float | None,
    ) -> None:
        self.line, self.group_map = line, group_map
        self.wide, self.column = wide, column
        self.goal_heading_rad = goal_heading_rad
        self.explicit = explicit  # the goal's heading, if the goal gave one

    def lay(
        self, s_m: float, *, wide: bool, at_goal: bool
    ) -> tuple[FloatArray, FloatArray, FloatArray] | None:
        """(places [m], headings [rad], route stations [m], NaN off the route) of the group
        centred ``s_m`` along the route, or None where it does not fit. At the goal the
        group faces the goal's heading, and a column is not moved off it."""
        line, count = self.line, self.wide.shape[0]
        centre = line.at(s_m)
        if wide:
            heading = self.goal_heading_rad if at_goal else line.heading(s_m)
            laid = places(_xy(centre), heading, self.wide)
            if self.group_map is not None and not _fits(self.group_map, centre, laid):
                return None
            return laid, np.full(count, heading), np.full(count, np.nan)
        if at_goal and self.explicit is not None:  # a column facing the goal's heading
            laid = places(_xy(centre), self.explicit, self.column)
            if self.group_map is None or _fits(self.group_map, centre, laid):
                return laid, np.full(count, self.explicit), np.full(count, np.nan)
        ahead = _column_stations(line, s_m + self.column[:, 0], self.group_map, movable=not at_goal)
        if ahead is None:
            return None
        return self._column(np.array(ahead), at_goal=at_goal)

    def can_change(self, s_m: float, *, to_wide: bool, at_goal: bool) -> bool:
        """The group, centred ``s_m`` along the route, can change its shape there: both shapes
        fit, and each robot sees its new place from its old one (no wall between: a column
        straddling a door does not spread out until all of it is through)."""
        old = self.lay(s_m, wide=not to_wide, at_goal=at_goal)
        new = self.lay(s_m, wide=to_wide, at_goal=at_goal)
        if old is None or new is None:
            return False
        if self.group_map is None:
            return True
        order = _regroup(old[0], new[0])
        return all(self.group_map.sees(a, b) for a, b in zip(old[0], new[0][order], strict=True))

    def fits_along(self, a_m: float, b_m: float) -> bool:
        """The formation fits all along the route from ``a_m`` to ``b_m`` (tried every
        FIT_EVERY_M)."""
        if self.group_map is None:
            return True
        line = self.line
        for s in np.linspace(a_m, b_m, math.ceil(abs(b_m - a_m) / FIT_EVERY_M) + 1):
            centre = line.at(float(s))
            if not _fits(self.group_map, centre, places(_xy(centre), line.heading(s), self.wide)):
                return False
        return True

    def onward(
        self,
        laid: tuple[FloatArray, FloatArray, FloatArray],
        before_m: FloatArray,
        *,
        at_goal: bool,
    ) -> tuple[FloatArray, FloatArray, FloatArray] | None:
        """A column ``laid`` moved on to at least where it stood before (``before_m``, route
        stations [m]), or None if it would not move at all."""
        ahead = np.maximum(laid[2], before_m)
        if not at_goal and np.allclose(ahead, before_m, atol=1e-6):
            return None
        return self._column(ahead, at_goal=at_goal)

    def _column(
        self, ahead_m: FloatArray, *, at_goal: bool
    ) -> tuple[FloatArray, FloatArray, FloatArray]:
        count, line = ahead_m.shape[0], self.line
        turned = [self.goal_heading_rad] * count if at_goal else [line.heading(a) for a in ahead_m]
        return np.array([line.at(a) for a in ahead_m]), np.array(turned), ahead_m


def _shape_plan(
    stations_m: list[float], keep: list[bool], layer: _Layer, column_step_m: float
) -> list[tuple[float, bool]]:
    """(station [m], in the formation asked for) of each place in turn: the steps; at each
    change of shape a step where the group changes it standing (laid in the new shape where
    it stood, or else in the old shape where it goes, when it fits there); and from a column
    to a column, more places between, at most ``column_step_m`` apart (the next robot's
    place is then clear of the one ahead, which has not left it yet)."""
    last = stations_m[-1]
    plan: list[tuple[float, bool]] = []
    for s, wide in zip(stations_m, keep, strict=True):
        if plan and plan[-1][1] != wide:
            before = plan[-1][0]
            # spread out standing only where the formation then fits all the way on
            if layer.can_change(before, to_wide=wide, at_goal=False) and (
                not wide or layer.fits_along(before, s)
            ):
                plan.append((before, wide))
            elif layer.can_change(s, to_wide=wide, at_goal=s == last):
                plan.append((s, not wide))
            else:
                raise GroupGoalError(_no_room_to_change(layer.line.at(before), layer.line.at(s)))
        plan.append((s, wide))
    out = plan[:1]
    for (a, wide_a), (b, wide_b) in itertools.pairwise(plan):
        if not wide_a and not wide_b and b - a > column_step_m:
            parts = math.ceil((b - a) / column_step_m)
            out += [(a + j * (b - a) / parts, False) for j in range(1, parts)]
        out.append((b, wide_b))
    return out


def _column_stations(
    line: _Polyline, stations_m: FloatArray, group_map: GroupMap | None, *, movable: bool
) -> list[float] | None:
    """[m] where along the route a column stands: at ``stations_m``, or, if a place there is
    off the route's ends and in a wall and the column is ``movable`` (not at the goal, where
    its centre must be), moved along until all of it is on the route (when the route is long
    enough to hold it); None if it does not fit."""
    if group_map is None:
        return [float(a) for a in stations_m]
    tries = [stations_m]
    if movable and stations_m.max() - stations_m.min() <= line.length_m:
        moved = stations_m - min(stations_m.min(), 0.0)
        tries.append(moved - max(moved.max() - line.length_m, 0.0))
    radius = group_map.radius_m
    ends = (line.at(0.0), line.at(line.length_m))
    for at in tries:
        points = np.array([line.at(a) for a in at])
        off = [  # a place off the route's ends must be seen from its end, not behind a wall
            group_map.sees(ends[int(a > 0)], p)
            for a, p in zip(at, points, strict=True)
            if a < 0 or a > line.length_m
        ]
        if (group_map.clearance_m(points) >= radius).all() and all(off):
            return [float(a) for a in at]
    return None


def _no_room_to_change(a_m: FloatArray, b_m: FloatArray) -> str:
    return (
        f"the group has no room to change its shape between ({a_m[0]:.2f}, {a_m[1]:.2f}) m and "
        f"({b_m[0]:.2f}, {b_m[1]:.2f}) m: try a smaller spacing, a longer --step or another goal"
    )


def _centre_route(
    start_m: FloatArray,
    goal_xy_m: tuple[float, float],
    goal_heading_rad: float | None,
    group_map: GroupMap | None,
) -> FloatArray:
    """[m] N x 2: the centre's route, straight without a map; one shorter than MIN_ROUTE_M
    (the goal where the centre is) is laid that long along the goal's heading (or east),
    ending at the goal."""
    if group_map is None:
        route = np.vstack([start_m, np.asarray(goal_xy_m, dtype=np.float64)])
    else:
        route = group_map.route((float(start_m[0]), float(start_m[1])), goal_xy_m)
    if float(np.hypot(*np.diff(route, axis=0).T).sum()) < MIN_ROUTE_M:
        ahead = goal_heading_rad if goal_heading_rad is not None else 0.0
        way_on = np.array([math.cos(ahead), math.sin(ahead)])
        route = np.vstack([route[-1] - MIN_ROUTE_M * way_on, route[-1]])
    return route


def _xy(point: FloatArray) -> tuple[float, float]:
    return float(point[0]), float(point[1])


def _fits(group_map: GroupMap, centre_m: FloatArray, places_m: FloatArray) -> bool:
    """Every place is clear by the radius and FIT_SLACK_M, and seen from the centre."""
    clear = group_map.radius_m + FIT_SLACK_M
    if not (group_map.clearance_m(places_m) >= clear).all():
        return False
    return all(group_map.sees(centre_m, p) for p in places_m)


def _regroup(from_m: FloatArray, to_m: FloatArray) -> npt.NDArray[np.int64]:
    """For each robot at ``from_m``, its place of ``to_m`` when the shape changes: the least
    sum of squared distances, so nobody overtakes (a column forms in the order the robots
    already stand, and spreads out without crossing)."""
    d2 = ((from_m[:, None, :] - to_m[None, :, :]) ** 2).sum(axis=2)
    rows, cols = linear_sum_assignment(d2)
    order = np.empty(len(rows), dtype=np.int64)
    order[rows] = cols
    return order
