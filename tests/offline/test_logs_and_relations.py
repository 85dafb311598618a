"""Log readers, the relation metric, and `navd replay` / `navd eval relations` end to end."""

from __future__ import annotations

import gzip
import itertools
import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from navd.bench.synthetic_room import cast
from navd.cli import main
from navd.geometry import Pose2, scan_points
from navd.offline.errors import LogFormatError
from navd.offline.logfiles import open_log, read_carmen
from navd.offline.relations import Relation, evaluate, read_relations, read_tum
from navd.offline.replay import tum_line
from navd.slam import load_map, load_map_state, relocalize, voxel_downsample
from tests.datasets import dataset


def _write_dump(folder: Path, poses: list[Pose2], drift: bool = False) -> Path:
    """A <name>_scans.txt.gz / _odom.txt.gz pair of the synthetic room, one scan per pose.

    With ``drift``, odometry overestimates every step by 8% and turns 0.3 deg too far.
    """
    odometry = [poses[0]]
    for a, b in itertools.pairwise(poses):
        step = a.between(b)
        wrong = Pose2(1.08 * step.x, 1.08 * step.y, step.yaw + (math.radians(0.3) if drift else 0))
        odometry.append(odometry[-1].compose(wrong if drift else step))
    scans = ["# stamp angle_min angle_increment range_min range_max n r_1 ... r_n"]
    odom = ["# stamp x y theta vx wz"]
    for i, pose in enumerate(poses):
        a0, inc, r = cast(pose, beams=360)
        r = np.where(np.isfinite(r), r, 80.0)
        scans.append(
            f"{100 + 0.1 * i:.6f} {a0:.8f} {inc:.8f} 0.1 80.0 {r.size} "
            + " ".join(f"{v:.3f}" for v in r)
        )
        o = odometry[i]
        odom.append(f"{100 + 0.1 * i:.6f} {o.x:.6f} {o.y:.6f} {o.yaw:.6f} 0 0")
    path = folder / "room_scans.txt.gz"
    with gzip.open(path, "wt") as f:
        f.write("\n".join(scans) + "\n")
    with gzip.open(folder / "room_odom.txt.gz", "wt") as f:
        f.write("\n".join(odom) + "\n")
    return path


PATH = [Pose2(-2.0 + 0.05 * i, -1.0 + 0.02 * i, 0.01 * i) for i in range(60)]


def test_replay_writes_every_output_and_tracks_the_synthetic_drive(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    log = _write_dump(tmp_path, PATH, drift=True)
    out = tmp_path / "out"
    assert main(["replay", str(log), "--out", str(out), "--quiet"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert sorted(p.name for p in out.iterdir()) == [
        "map.npz",
        "map.pgm",
        "map.png",
        "map.yaml",
        "summary.json",
        "trajectory.tum",
    ]
    assert summary == json.loads((out / "summary.json").read_text())
    assert summary["scans"] == 60 and summary["data_seconds"] == pytest.approx(5.9)
    assert (out / "map.png").read_bytes().startswith(b"\x89PNG\r\n\x1a\n")
    stamps, poses = read_tum(out / "trajectory.tum")
    # Odometry drifts by tens of centimetres; matching on the map keeps the track within a
    # cell of the truth.
    errors = [math.hypot(p.x - t.x, p.y - t.y) for p, t in zip(poses, PATH, strict=True)]
    assert max(errors) < 0.05
    relations = tmp_path / "room.relations"
    lines = []
    for i in range(0, 50, 5):
        delta = PATH[i].between(PATH[i + 10])
        lines.append(f"{stamps[i]} {stamps[i + 10]} {delta.x} {delta.y} 0 0 0 {delta.yaw}\n")
    relations.write_text("".join(lines))
    code = main(["eval", "relations", str(out / "trajectory.tum"), str(relations), "--json"])
    report = json.loads(capsys.readouterr().out)
    assert code == 0
    assert report["used"] == 10 and report["translation_mean_m"] < 0.05


def test_relation_metric_is_zero_for_the_truth_and_measures_a_known_error() -> None:
    stamps = [float(i) for i in range(len(PATH))]
    relations = [Relation(float(i), float(i + 5), PATH[i].between(PATH[i + 5])) for i in range(50)]
    exact = evaluate(stamps, PATH, relations)
    assert exact.used == 50 and exact.translation_mean_m < 1e-12
    shifted = [p if i < 30 else Pose2(p.x + 0.1, p.y, p.yaw) for i, p in enumerate(PATH)]
    errors = evaluate(stamps, shifted, relations)
    # Relations spanning index 30 (starts 25..29) see the 0.1 m jump; the other 45 do not.
    assert errors.translation_mean_m == pytest.approx(0.1 * 5 / 50, rel=1e-6)
    missing = evaluate(stamps[:10], PATH[:10], relations)
    assert missing.used == 5 and missing.missing == 45


def test_tum_lines_carry_the_yaw_as_a_z_rotation() -> None:
    t, x, y, z, qx, qy, qz, qw = (float(v) for v in tum_line(1.5, Pose2(1, 2, 2.0)).split())
    assert (t, x, y, z, qx, qy) == (1.5, 1.0, 2.0, 0.0, 0.0, 0.0)
    assert 2 * math.atan2(qz, qw) == pytest.approx(2.0, abs=1e-8)


def test_malformed_logs_and_relations_are_named(tmp_path: Path) -> None:
    bad = tmp_path / "x_scans.txt"
    bad.write_text("# header\n1.0 -1.5 0.01 0.1 30 3 1.0 2.0\n")
    with pytest.raises(LogFormatError, match=r"x_scans.txt:2: expected .* n and n ranges"):
        list(open_log(bad))
    with pytest.raises(LogFormatError, match="unknown log format"):
        open_log(_touch(tmp_path / "data.bin"))
    rel = tmp_path / "bad.relations"
    rel.write_text("1 2 3\n")
    with pytest.raises(LogFormatError, match=r"bad.relations:1: expected 't1 t2 x y z roll"):
        read_relations(rel)
    assert main(["eval", "relations", str(tmp_path / "none.tum"), str(rel)]) == 2


def _touch(path: Path) -> Path:
    path.write_bytes(b"")
    return path


def test_replay_scan_ranges_and_maps_that_cannot_be_used_are_named(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    log = _write_dump(tmp_path, PATH)
    out = str(tmp_path / "out")
    for scans, says in (
        ("5:5", "TO greater than FROM"),
        ("7", "give FROM:TO"),
        ("a:b", "whole numbers"),
        ("100000:", "picked no scans"),
    ):
        assert main(["replay", str(log), "--out", out, "--quiet", "--scans", scans]) == 2
        assert says in capsys.readouterr().err
    missing = tmp_path / "nowhere.yaml"
    assert main(["replay", str(log), "--out", out, "--quiet", "--map", str(missing)]) == 2
    err = capsys.readouterr().err
    assert "--map" in err and str(missing) in err
    # A part of the log: only those scans are mapped.
    assert main(["replay", str(log), "--out", out, "--quiet", "--scans", "2:6"]) == 0
    capsys.readouterr()
    stamps, _ = read_tum(tmp_path / "out" / "trajectory.tum")
    assert len(stamps) == 4


def test_carmen_flaser_lines_are_read_with_their_odometry(tmp_path: Path) -> None:
    log = tmp_path / "tiny.clf"
    ranges = " ".join(["1.50"] * 5)
    log.write_text(
        "# CARMEN log\n"
        f"FLASER 5 {ranges} 1.0 2.0 0.5 1.0 2.0 0.5 1134864629.895182 b21 0.086\n"
        "ODOM 1 2 0.5 0 0 0 1134864629.9 b21 0.1\n"
    )
    (scan,) = list(read_carmen(log))
    assert scan.stamp == 1134864629.895182
    assert scan.angle_min == pytest.approx(-math.pi / 2)
    assert scan.angle_increment == pytest.approx(math.pi / 4)
    assert scan.odom == Pose2(1.0, 2.0, 0.5)


def test_intel_replay_beats_gmapping_on_the_published_relations(tmp_path: Path) -> None:
    freiburg = dataset("freiburg_slam_benchmark")
    log = freiburg / "derived_txt" / "intel_scans.txt.gz"
    assert main(["replay", str(log), "--out", str(tmp_path), "--quiet"]) == 0
    stamps, poses = read_tum(tmp_path / "trajectory.tum")
    errors = evaluate(stamps, poses, read_relations(freiburg / "relations" / "intel.relations"))
    assert errors.used == 2984
    # With the defaults (loop closure on): 0.0247 m measured (0.0275 m before the reported
    # pose was refined on the fine map, 0.0261 m before the odometry pulled harder along
    # corridors); issue 19's target 0.025 m, GMapping 0.070 m, graph mapping 0.031 m,
    # Cartographer 0.0229 m. Held to 0.0255 m: without the refinement it fails.
    assert errors.translation_mean_m <= 0.0255
    assert errors.rotation_mean_deg <= 0.5
    # Localization on the saved map, for every 500th scan: from a 0.5 m / 15 degree wrong
    # start, and from nothing. Measured (27 scans): 26 and 25 found. From nothing, a search
    # on the map coarsened 4 times (20 cm cells) found 21: look-alike rooms scored as well
    # as the true place there (scan 12000: 1.5 m and 88 degrees off). What is missed is found
    # just outside a limit, where two passes drew a corridor a little apart: scan 7000 from
    # the wrong start 0.14 m and 2.9 degrees off (the 0.05 rad limit), from nothing 0.17 m
    # off; scan 1500 from nothing 0.16 m off.
    grid = load_map(tmp_path / "map.yaml")
    from_guess = from_nothing = samples = 0
    for index, scan in enumerate(open_log(log)):
        if index == 0 or index % 500:
            continue
        truth = poses[index]
        points = voxel_downsample(
            scan_points(
                scan.ranges,
                scan.angle_min,
                scan.angle_increment,
                range_min=0.1,
                range_max=scan.range_max,
                max_range=12.0,
            ).hits,
            0.1,
        )
        wrong = truth.compose(Pose2(0.3, 0.4, math.radians(15.0)))
        guessed, anywhere = relocalize(grid, points, guess=wrong), relocalize(grid, points)
        samples += 1
        from_guess += _near(guessed.pose, truth, 0.25)
        from_nothing += _near(anywhere.pose, truth, 0.15)
    assert samples == 27
    assert from_guess >= 25
    assert from_nothing >= 24


def _near(found: Pose2, truth: Pose2, tolerance_m: float) -> bool:
    """Within ``tolerance_m`` and 0.05 rad of ``truth``."""
    off = math.hypot(found.x - truth.x, found.y - truth.y)
    return off < tolerance_m and abs(math.remainder(found.yaw - truth.yaw, 2 * math.pi)) < 0.05


def test_aces_replay_with_the_defaults_closes_its_loops(tmp_path: Path) -> None:
    freiburg = dataset("freiburg_slam_benchmark")
    bag = freiburg / "bags_ros1" / "aces.orig.bag"
    assert main(["replay", str(bag), "--out", str(tmp_path), "--quiet"]) == 0
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["loops_found"] > 0 and summary["loops_ambiguous"] > 0
    stamps, poses = read_tum(tmp_path / "trajectory.tum")
    relations = read_relations(freiburg / "relations" / "aces.relations")
    errors = evaluate(stamps, poses, relations)
    assert errors.used == 1279
    # 0.0395 m measured with the defaults (0.0388 m before the reported pose was refined on
    # the fine map, 0.060 m before the odometry pulled harder along a corridor, 0.084 m
    # while the way out and back of a dead-end corridor was one pass searched from its end,
    # 0.185 m before loop closure was on by default); GMapping 0.060 m, Cartographer
    # 0.0375 m, issue 19's target 0.040 m. Held to 0.042 m so that a last bit computed
    # otherwise elsewhere cannot flip it; the build before the weak axis's pull breaks it.
    assert errors.translation_mean_m <= 0.042
    assert errors.rotation_mean_deg <= 0.6
    # Most of the building is right: the median relation is within 5 cm.
    each = sorted(evaluate(stamps, poses, [r]).translation_mean_m for r in relations)
    assert each[len(each) // 2] <= 0.05


# The replay in a process of its own, which prints its peak resident set [kB] when done:
# VmHWM, its own memory's high-water mark. (Not ru_maxrss: on Linux that keeps the mark of
# the process it was forked from across exec, here the test run's own, near 1 GB.)
# The replay's peak as on the robot: rich (and pygments with it) come only with the dev-only
# peers (kiss-icp), and structlog imports rich whenever it is installed: 7 MB the board never
# holds. Kept out here as it is absent there.
PEAK_RSS_SCRIPT = """
import sys
sys.modules["rich"] = None
from navd.cli import main
code = main(sys.argv[1:])
with open("/proc/self/status") as status:
    print(next(line.split()[1] for line in status if line.startswith("VmHWM:")))
sys.exit(code)
"""


def test_fr_clinic_replay_with_the_defaults_closes_its_loops_in_300_mb(tmp_path: Path) -> None:
    freiburg = dataset("freiburg_slam_benchmark")
    bag = freiburg / "bags_ros1" / "fr-clinic_robotlaser.orig.bag"
    command = ["replay", str(bag), "--out", str(tmp_path), "--quiet"]
    run = subprocess.run(
        [sys.executable, "-c", PEAK_RSS_SCRIPT, *command],
        capture_output=True,
        text=True,
        check=False,
        timeout=600,
    )
    assert run.returncode == 0, run.stderr
    # A 244 x 432 m map at 5 cm: 41 million cells, 162 MB dense, and 684 MB at the peak
    # before the grid was tiled. Issue 19's bar for a robot board is 300 MB.
    peak_mb = int(run.stdout.split()[-1]) / 1024
    assert peak_mb <= 300.0
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["loops_found"] > 0
    stamps, poses = read_tum(tmp_path / "trajectory.tum")
    relations = read_relations(freiburg / "relations" / "fr-clinic.relations")
    errors = evaluate(stamps, poses, relations)
    assert errors.used == 2820
    # 0.126 m measured (2.73 m with the defaults before); scan matching 0.434 m, graph
    # mapping 0.143 m, Cartographer 0.108 m (Kümmerle et al. 2009, Hess et al. 2016).
    assert errors.translation_mean_m <= 0.15
    # The loops are closed: relations whose stamps lie 600 s or more apart (across the
    # loops, where odometry and scan matching alone are metres off) are within a metre.
    far = [r for r in relations if abs(r.t2 - r.t1) >= 600.0]
    assert len(far) > 100
    far_errors = evaluate(stamps, poses, far)
    assert far_errors.translation_mean_m <= 1.0


def test_replay_with_scan_odometry_needs_no_wheels(tmp_path: Path) -> None:
    log = _write_dump(tmp_path, PATH, drift=True)  # the log's odometry is ignored
    out = tmp_path / "out"
    assert main(["replay", str(log), "--out", str(out), "--quiet", "--odometry", "scan"]) == 0
    _, poses = read_tum(out / "trajectory.tum")
    # kiss-icp's frame starts at the first scan: compare motions from there.
    errors = [
        math.hypot(*PATH[0].between(t).compose(poses[0].between(p).inverse())[:2])
        for p, t in zip(poses, PATH, strict=True)
    ]
    assert max(errors) < 0.05


# Measured with the defaults (the tests above bound them).
ACES_UNPERTURBED_M, INTEL_DUMP_UNPERTURBED_M, CLINIC_UNPERTURBED_M = 0.0395, 0.0247, 0.126


@pytest.mark.parametrize(
    ("log", "kind"),
    [
        ("aces", "drop"),
        ("aces", "odometry"),
        ("aces", "range8"),
        ("intel_dump", "odometry"),
        ("fr-clinic", "range8"),
    ],
)
def test_replays_hold_with_scans_lost_worse_wheels_and_a_shorter_lidar(
    tmp_path: Path, log: str, kind: str
) -> None:
    # A tenth of the scans dropped, wheels 5 % long whose heading drifts 2 degrees a minute,
    # or a lidar that sees 8 m: the defaults stay within twice the unperturbed error (issue
    # 19's bar). Measured: aces 0.0401, 0.0409 and 0.0411 m, the dump 0.0269 m, fr-clinic
    # 0.112 m (docs/slam.md, "Perturbed logs"; fr-clinic with an 8 m lidar was 1.18 m before
    # loops beyond the window cap were searched and confirmed); aces with worse wheels and
    # with an 8 m lidar gave 0.120 and 0.277 m before the odometry pulled harder along
    # corridors.
    freiburg = dataset("freiburg_slam_benchmark")
    if log == "aces":
        source = freiburg / "bags_ros1" / "aces.orig.bag"
        name, unperturbed = "aces", ACES_UNPERTURBED_M
    elif log == "fr-clinic":
        source = freiburg / "bags_ros1" / "fr-clinic_robotlaser.orig.bag"
        name, unperturbed = "fr-clinic", CLINIC_UNPERTURBED_M
    else:
        source = freiburg / "derived_txt" / "intel_scans.txt.gz"
        name, unperturbed = "intel", INTEL_DUMP_UNPERTURBED_M
    args = ["replay", str(source), "--out", str(tmp_path), "--quiet", "--perturb", kind]
    assert main([*args, "--seed", "0"]) == 0
    stamps, poses = read_tum(tmp_path / "trajectory.tum")
    errors = evaluate(stamps, poses, read_relations(freiburg / "relations" / f"{name}.relations"))
    assert errors.used > 1000
    assert errors.translation_mean_m <= 2.0 * unperturbed


def test_a_second_run_on_the_first_halfs_map_closes_loops_onto_it(tmp_path: Path) -> None:
    # aces in two halves, as two days of mapping: the second replay starts on the first's
    # saved map and graph, is found on it by its first scan, maps on and closes loops onto
    # the first run's keyframes.
    freiburg = dataset("freiburg_slam_benchmark")
    bag = str(freiburg / "bags_ros1" / "aces.orig.bag")
    first, second = tmp_path / "first", tmp_path / "second"
    assert main(["replay", bag, "--out", str(first), "--scans", "0:3687", "--quiet"]) == 0
    saved = load_map_state(first / "map.yaml")
    assert saved.graph is not None and len(saved.graph.keyframes) > 400
    args = ["replay", bag, "--out", str(second), "--scans", "3687:", "--quiet"]
    assert main([*args, "--map", str(first / "map.yaml")]) == 0
    summary = json.loads((second / "summary.json").read_text())
    assert summary["scans"] == 7374 - 3687
    assert summary["loaded_keyframes"] == len(saved.graph.keyframes)
    # Found where the first run left the robot (the next scan, 0.24 s later).
    _, before = read_tum(first / "trajectory.tum")
    x, y, _ = summary["found_at"]
    assert math.hypot(x - before[-1].x, y - before[-1].y) < 0.3
    assert summary["loops_to_loaded"] >= 5  # 34 measured
    # The second half is mapped nearly as well as in one run: 0.0412 m measured, against
    # 0.0388 m over the whole log (0.068 and 0.060 m before the odometry pulled harder along
    # corridors; 0.120 and 0.084 m with the loop window of the morning of 4 December: the
    # second half alone missed the east-wing loop the whole log closes).
    stamps, poses = read_tum(second / "trajectory.tum")
    errors = evaluate(stamps, poses, read_relations(freiburg / "relations" / "aces.relations"))
    assert errors.used > 500
    assert errors.translation_mean_m <= 0.10
    assert errors.rotation_mean_deg <= 0.6
