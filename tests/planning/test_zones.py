"""Zone masks drawn as images: read as map_server reads them, placed on the planner's grids,
a keep-out mask that blocks a corridor, a speed mask that slows the robot inside it, and a
mask redrawn while navd runs taking effect at the next plan."""

from __future__ import annotations

import dataclasses
import math
import os
import struct
import zlib
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from PIL import Image

from navd.config import NavdConfig
from navd.geometry import MapYaml, Pose2, occupancy_of
from navd.planning.costmap import GridFrame
from navd.planning.errors import PlanningError
from navd.planning.goal import NavGoal
from navd.planning.guard_node import CollisionGuard
from navd.planning.layers import Layers
from navd.planning.navigator import Navigator
from navd.planning.settings import NavigatorSettings, guard_settings, layer_settings
from navd.planning.zones import RECHECK_S, ZoneError, ZoneMasks, load_zone_mask
from tests.planning.drive import drive, rasterize

RES = 0.05
ORIGIN = (-1.0, -3.0)
SHAPE = (120, 240)  # rows (y), cols (x): 6 m x 12 m from the origin


def write_mask(
    folder: Path, name: str, grey: np.ndarray, *, png: bool = False, mode: str = "trinary"
) -> Path:
    """A map_server mask: ``grey`` (bottom row first, as the map's rows) as an image."""
    image = folder / f"{name}.{'png' if png else 'pgm'}"
    top_first = np.ascontiguousarray(grey[::-1].astype(np.uint8))
    if png:
        Image.fromarray(top_first, mode="L").save(image)
    else:
        rows, cols = top_first.shape
        image.write_bytes(f"P5\n{cols} {rows}\n255\n".encode() + top_first.tobytes())
    yaml = folder / f"{name}.yaml"
    yaml.write_text(
        f"image: {image.name}\nresolution: {RES}\norigin: [{ORIGIN[0]}, {ORIGIN[1]}, 0.0]\n"
        f"negate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\nmode: {mode}\n"
    )
    return yaml


def _cells(x0: float, x1: float, y0: float, y1: float) -> tuple[slice, slice]:
    """The mask's rows and columns covering x0..x1, y0..y1 [m]."""
    return (
        slice(round((y0 - ORIGIN[1]) / RES), round((y1 - ORIGIN[1]) / RES)),
        slice(round((x0 - ORIGIN[0]) / RES), round((x1 - ORIGIN[0]) / RES)),
    )


def test_map_server_modes_read_as_it_does() -> None:
    grey = np.array([[0, 254, 205, 128]], dtype=np.uint8)
    trinary = MapYaml("m.pgm", 0.05, (0.0, 0.0, 0.0))
    assert occupancy_of(trinary, grey).tolist() == [[100, 0, -1, -1]]
    scale = MapYaml("m.pgm", 0.05, (0.0, 0.0, 0.0), mode="scale")
    assert occupancy_of(scale, grey)[0, 3] == round(99 * ((127 / 255) - 0.196) / (0.65 - 0.196))
    raw = MapYaml("m.pgm", 0.05, (0.0, 0.0, 0.0), mode="raw")
    assert occupancy_of(raw, np.array([[30, 100, 101]], dtype=np.uint8)).tolist() == [[30, 100, -1]]
    negated = MapYaml("m.pgm", 0.05, (0.0, 0.0, 0.0), negate=1)
    assert occupancy_of(negated, grey).tolist()[0][:2] == [0, 100]


@pytest.mark.parametrize("png", [False, True])
def test_a_mask_lies_where_its_yaml_puts_it(tmp_path: Path, png: bool) -> None:
    grey = np.full(SHAPE, 254, dtype=np.uint8)
    grey[_cells(2.0, 3.0, 0.0, 0.5)] = 0  # a keep-out block
    mask = load_zone_mask(write_mask(tmp_path, "keep", grey, png=png))
    assert mask.value_at(2.5, 0.25) == 100 and mask.value_at(1.9, 0.25) == 0
    assert mask.value_at(-5.0, 0.0) == -1  # outside the image
    # placed on another grid (offset by half a cell, coarser): the same block
    frame = GridFrame(0.1, -0.975, -2.975, 50, 100)
    cells = mask.cells_on(frame)
    xs = frame.origin_x_m + (np.arange(frame.cols) + 0.5) * 0.1
    blocked_cols = np.nonzero((cells >= 100).any(axis=0))[0]
    assert xs[blocked_cols].min() > 1.95 and xs[blocked_cols].max() < 3.05


def test_a_broken_or_missing_mask_refuses_plans_by_name(tmp_path: Path) -> None:
    zones = ZoneMasks(str(tmp_path / "nope.yaml"), None)
    with pytest.raises(ZoneError, match=r"nope\.yaml"):
        zones.check()
    (tmp_path / "bad.yaml").write_text("image: bad.pgm\nresolution: 0.05\norigin: [0, 0, 0]\n")
    (tmp_path / "bad.pgm").write_bytes(b"P5\n4 4\n255\n\x00")
    with pytest.raises(ZoneError, match="truncated"):
        ZoneMasks(str(tmp_path / "bad.yaml"), None).check()
    config = NavdConfig.model_validate({"planning": {"keep_out_mask": str(tmp_path / "nope.yaml")}})
    nav = Navigator(NavigatorSettings.from_config(config))
    nav.set_goal(NavGoal("g", 1.0, 0.0))
    with pytest.raises(PlanningError, match=r"nope\.yaml"):
        nav.plan(0.0, Pose2(0.0, 0.0, 0.0))


def _png_claiming(path: Path, cols: int, rows: int) -> None:
    """A few hundred bytes of PNG whose header claims ``cols`` x ``rows`` grey pixels."""

    def chunk(kind: bytes, data: bytes) -> bytes:
        body = kind + data
        return struct.pack(">I", len(data)) + body + struct.pack(">I", zlib.crc32(body))

    header = struct.pack(">IIBBBBB", cols, rows, 8, 0, 0, 0, 0)
    idat = zlib.compress(b"\x00" * 4096)
    path.write_bytes(
        b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", idat) + chunk(b"IEND", b"")
    )


@pytest.mark.parametrize("side", [13_000, 20_000])
def test_a_mask_claiming_billions_of_pixels_is_refused_before_it_is_decoded(
    tmp_path: Path, side: int
) -> None:
    _png_claiming(tmp_path / "bomb.png", side, side)
    (tmp_path / "bomb.yaml").write_text(
        "image: bomb.png\nresolution: 0.05\norigin: [0, 0, 0]\n", encoding="utf-8"
    )
    with pytest.raises(ZoneError, match=f"{side} x {side} pixels|more pixels than"):
        ZoneMasks(str(tmp_path / "bomb.yaml"), None).check()


# Two corridors from x = 0 to x = 9 side by side: the lower one (y -1..0) is the short way
# to the goal, the upper one (y 0.6..1.6) goes round.
WALLS = np.array(
    [
        [-1.0, -1.0, 10.0, -1.0],
        [1.0, 0.3, 8.0, 0.3],  # the wall between the corridors, open at both ends
        [-1.0, 2.0, 10.0, 2.0],
        [-1.0, -1.0, -1.0, 2.0],
        [10.0, -1.0, 10.0, 2.0],
    ]
)


def _config(**planning: object) -> NavdConfig:
    return NavdConfig.model_validate({"planning": planning})


def test_a_keep_out_mask_closes_a_corridor(tmp_path: Path) -> None:
    goal = NavGoal("g", 9.0, -0.4)
    free = drive(_config(), WALLS, Pose2(0.0, -0.4, 0.0), goal, map_box=(-2, -3, 11, 3))
    assert free.state is not None and free.state.value == "reached"
    assert max(p.y for p in free.poses) < 0.3  # straight along the lower corridor
    grey = np.full(SHAPE, 254, dtype=np.uint8)
    grey[_cells(4.0, 4.5, -1.0, 0.3)] = 0  # a band across the lower corridor
    yaml = write_mask(tmp_path, "keep", grey)
    closed = drive(
        _config(keep_out_mask=str(yaml)),
        WALLS,
        Pose2(0.0, -0.4, 0.0),
        goal,
        map_box=(-2, -3, 11, 3),
    )
    assert closed.state is not None and closed.state.value == "reached"
    assert max(p.y for p in closed.poses) > 0.6  # round by the upper corridor
    inside = [p for p in closed.poses if 4.0 <= p.x <= 4.5 and p.y < 0.3]
    assert inside == []


def test_a_speed_zone_slows_the_robot_to_its_limit_inside_it(tmp_path: Path) -> None:
    grey = np.zeros(SHAPE, dtype=np.uint8)  # raw mode: 0 sets no limit
    grey[_cells(3.0, 6.0, -1.0, 0.3)] = 30  # 30 % of the top speed
    yaml = write_mask(tmp_path, "speed", grey, mode="raw")
    config = _config(speed_mask=str(yaml))
    top = config.robot.max_linear_speed_mps
    run = drive(
        config, WALLS, Pose2(0.0, -0.4, 0.0), NavGoal("g", 9.0, -0.4), map_box=(-2, -3, 11, 3)
    )
    assert run.state is not None and run.state.value == "reached"
    speeds = [v for (v, _), p in zip(run.commands, run.poses, strict=False) if 3.3 <= p.x <= 5.7]
    outside = [v for (v, _), p in zip(run.commands, run.poses, strict=False) if 7.0 <= p.x <= 8.0]
    assert speeds and max(speeds) <= 0.3 * top + 1e-6
    assert max(outside) > 0.8 * top  # full speed again beyond it


def test_a_mask_redrawn_while_driving_takes_effect_at_the_next_plan(tmp_path: Path) -> None:
    grey = np.full(SHAPE, 254, dtype=np.uint8)
    yaml = write_mask(tmp_path, "keep", grey)
    nav = Navigator(NavigatorSettings.from_config(_config(keep_out_mask=str(yaml))))
    rows, cols = round(6.0 / RES), round(13.0 / RES)
    nav.set_map(rasterize(WALLS, RES, (-2.0, -3.0), (rows, cols)), RES, -2.0, -3.0)
    nav.set_goal(NavGoal("g", 9.0, -0.4))
    start = Pose2(0.0, -0.4, 0.0)
    first = nav.plan(0.0, start)
    assert max(y for _, y in first.points_m) < 0.3
    grey[_cells(4.0, 4.5, -1.0, 0.3)] = 0  # a person closes the lower corridor
    write_mask(tmp_path, "keep", grey)
    os.utime(tmp_path / "keep.pgm", ns=(0, 10**18))  # a new modification time, surely
    again = nav.plan(RECHECK_S + 0.1, start)
    assert max(y for _, y in again.points_m) > 0.6
    assert not any(4.0 <= x <= 4.5 and y < 0.3 for x, y in again.points_m)
    assert math.isfinite(again.length_m)


def test_the_collision_guard_holds_anyone_to_a_speed_zone(tmp_path: Path) -> None:
    grey = np.zeros(SHAPE, dtype=np.uint8)
    grey[_cells(3.0, 6.0, -1.0, 0.3)] = 30
    yaml = write_mask(tmp_path, "speed", grey, mode="raw")
    config = _config(speed_mask=str(yaml))
    guard = CollisionGuard()
    guard.settings = SimpleNamespace(value=guard_settings(config))  # type: ignore[assignment]
    guard.zones = ZoneMasks(None, str(yaml))
    top = config.robot.max_linear_speed_mps
    guard._pose = (1.0, 0.0)  # outside: a person's full speed goes through
    assert guard.limit(top, 0.3) == (top, 0.3, "")
    guard._pose = (4.0, -0.5)  # inside: held to 30 %, turning untouched, and said why
    linear, angular, reason = guard.limit(top, 0.3)
    assert linear == pytest.approx(0.3 * top) and angular == 0.3 and "speed zone" in reason
    assert guard.limit(-0.2, 0.0)[0] == pytest.approx(-0.3 * top)  # backing up too


def test_a_mask_swapped_for_another_file_is_the_one_kept_out_of(tmp_path: Path) -> None:
    first = np.full(SHAPE, 254, dtype=np.uint8)
    first[_cells(1.0, 1.5, 0.0, 0.5)] = 0
    second = np.full(SHAPE, 254, dtype=np.uint8)
    second[_cells(5.0, 5.5, 0.0, 0.5)] = 0
    a, b = write_mask(tmp_path, "a", first), write_mask(tmp_path, "b", second)
    settings = layer_settings(_config(keep_out_mask=str(a)).planning)
    layers = Layers(settings)
    frame = GridFrame(RES, ORIGIN[0], ORIGIN[1], *SHAPE)
    assert layers.keep_out(frame)[frame.cell_of(1.2, 0.2)]
    layers.configure(dataclasses.replace(settings, keep_out_mask=str(b)))
    cells = layers.keep_out(frame)  # the same frame: no stale cache of the first file
    assert cells[frame.cell_of(5.2, 0.2)] and not cells[frame.cell_of(1.2, 0.2)]
