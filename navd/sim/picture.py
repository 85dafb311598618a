"""The demo's picture: the world, the map navd built, the route, and both trajectories."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from navd.offline import encode_png
from navd.sim.world import World

__all__ = ["demo_picture", "fleet_picture"]

PIXEL_M = 0.025
WORLD_RGB = (215, 215, 215)  # the true obstacles, light grey
MAP_RGB = (20, 20, 20)  # what navd mapped as occupied, black
ROUTE_RGB = (40, 90, 230)  # the last route planned, blue
OLD_ROUTE_RGB = (170, 195, 245)  # earlier routes (replanned as the map grew), light blue
ESTIMATE_RGB = (20, 160, 60)  # where navd thought it was, green
TRUTH_RGB = (220, 30, 30)  # where the robot really went, red
MOVER_RGB = (240, 150, 20)  # moving obstacles' paths, orange
GOAL_RGB = (200, 0, 200)


class _Canvas:
    def __init__(self, world: World) -> None:
        x0, y0, x1, y1 = world.extent
        self.x0, self.y0 = x0, y0
        self.cols = math.ceil((x1 - x0) / PIXEL_M)
        self.rows = math.ceil((y1 - y0) / PIXEL_M)
        self.rgb = np.full((self.rows, self.cols, 3), 255, dtype=np.uint8)

    def pixels(
        self, xy: npt.NDArray[np.float64]
    ) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.int64]]:
        cols = np.floor((xy[:, 0] - self.x0) / PIXEL_M).astype(np.int64)
        rows = np.floor((xy[:, 1] - self.y0) / PIXEL_M).astype(np.int64)
        inside = (cols >= 0) & (cols < self.cols) & (rows >= 0) & (rows < self.rows)
        return rows[inside], cols[inside]

    def cells(
        self,
        mask: npt.NDArray[np.bool_],
        ox: float,
        oy: float,
        res: float,
        rgb: tuple[int, int, int],
    ) -> None:
        """Paint every pixel whose centre falls in a True cell of ``mask`` (any resolution)."""
        px = self.x0 + (np.arange(self.cols) + 0.5) * PIXEL_M
        py = self.y0 + (np.arange(self.rows) + 0.5) * PIXEL_M
        cols = np.floor((px - ox) / res).astype(np.int64)
        rows = np.floor((py - oy) / res).astype(np.int64)
        ok_c = (cols >= 0) & (cols < mask.shape[1])
        ok_r = (rows >= 0) & (rows < mask.shape[0])
        hit = np.zeros((self.rows, self.cols), dtype=np.bool_)
        hit[np.ix_(ok_r, ok_c)] = mask[np.ix_(rows[ok_r], cols[ok_c])]
        self.rgb[hit] = rgb

    def line(self, xy: npt.NDArray[np.float64], rgb: tuple[int, int, int], width: int = 1) -> None:
        if len(xy) == 0:
            return
        if len(xy) > 1:
            steps = np.maximum(1, np.ceil(np.hypot(*np.diff(xy, axis=0).T) / (PIXEL_M / 2))).astype(
                int
            )
            xy = np.vstack(
                [
                    np.linspace(a, b, n, endpoint=False)
                    for a, b, n in zip(xy[:-1], xy[1:], steps, strict=True)
                ]
                + [xy[-1:]]
            )
        for dr in range(-(width // 2), width // 2 + 1):
            for dc in range(-(width // 2), width // 2 + 1):
                r, c = self.pixels(xy + np.array([dc, dr]) * PIXEL_M)
                self.rgb[r, c] = rgb

    def disc(self, x: float, y: float, radius_m: float, rgb: tuple[int, int, int]) -> None:
        a = np.linspace(0, 2 * math.pi, 64)
        self.line(np.column_stack([x + radius_m * np.cos(a), y + radius_m * np.sin(a)]), rgb, 3)


def demo_picture(  # noqa: PLR0917 - every layer of the picture, named
    world: World,
    built: Any,
    routes: list[list[list[float]]],
    estimated: list[tuple[float, float, float]],
    truth: npt.NDArray[np.float64],
    path: Path,
) -> None:
    """Write the picture: true obstacles light grey, navd's map black, earlier routes light
    blue and the last one blue, estimated trajectory green, true trajectory red, moving
    obstacles' paths orange, start green and goal magenta circles."""
    canvas = _Canvas(world)
    # Draw the world at its own resolution, thinned to the picture's pixels.
    canvas.cells(world.grid, world.origin_x_m, world.origin_y_m, world.resolution_m, WORLD_RGB)
    if built is not None:
        occupied = built.occupancy_percent() >= 65
        canvas.cells(occupied, built.origin_x, built.origin_y, built.resolution, MAP_RGB)
    for mover in world.movers:
        canvas.line(mover.path_m, MOVER_RGB, 3)
    for i, route in enumerate(routes):
        last = i == len(routes) - 1
        points = np.array(route, dtype=np.float64).reshape(-1, 2)
        canvas.line(points, ROUTE_RGB if last else OLD_ROUTE_RGB, 3 if last else 1)
    canvas.line(
        np.array([e[:2] for e in estimated], dtype=np.float64).reshape(-1, 2), ESTIMATE_RGB, 3
    )
    canvas.line(truth[:, :2], TRUTH_RGB, 1)
    x0, y0, _ = world.start
    canvas.disc(x0, y0, 0.15, ESTIMATE_RGB)
    if world.goal is not None:
        canvas.disc(world.goal[0], world.goal[1], 0.2, GOAL_RGB)
    path.write_bytes(encode_png(canvas.rgb, bottom_up=True))


# each robot of a fleet in a colour of its own (cycled beyond six)
FLEET_RGB = (
    (220, 30, 30), (40, 90, 230), (20, 160, 60), (240, 150, 20), (150, 40, 200), (0, 170, 180),
)  # fmt: skip
CENTRE_RGB = (90, 90, 90)  # the group centre's route, dark grey


def fleet_picture(
    world: World,
    trajectories: list[npt.NDArray[np.float64]],
    goal_xy_m: tuple[float, float],
    path: Path,
    *,
    route_m: npt.NDArray[np.float64] | None = None,
) -> None:
    """A PNG of the world, the group centre's route (N x 2 [m], if given) in dark grey, each
    robot's way (N x 2 [m]) in its colour, a ring where each ended, and the group's goal."""
    canvas = _Canvas(world)
    canvas.cells(world.grid, world.origin_x_m, world.origin_y_m, world.resolution_m, WORLD_RGB)
    if route_m is not None and len(route_m) > 1:
        canvas.line(route_m, CENTRE_RGB, 1)
    for k, way in enumerate(trajectories):
        rgb = FLEET_RGB[k % len(FLEET_RGB)]
        canvas.line(way, rgb, 3)
        if len(way):
            canvas.disc(float(way[-1, 0]), float(way[-1, 1]), 0.25, rgb)
    canvas.disc(goal_xy_m[0], goal_xy_m[1], 0.1, GOAL_RGB)
    path.write_bytes(encode_png(canvas.rgb, bottom_up=True))
