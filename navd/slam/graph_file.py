"""The pose graph a map was built from, as flat arrays for the map's state file.

A map that is to go on growing in a later run needs more than its grid: its keyframes (the
stamp, pose, and scan of each, and whether the scan made the map), the graph's edges (the
tracked steps between keyframes and the loop constraints), and the map it was all drawn over
(a map loaded without a graph, if any). ``graph_arrays`` flattens them into named arrays for
``numpy.savez`` (scans concatenated, with each keyframe's end offsets); ``graph_from_arrays``
reads them back exactly, float64 for float64, so a map reloads bit for bit with its graph.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from navd.geometry import FieldOfView, Pose2, ScanPoints
from navd.slam.errors import MapFileError
from navd.slam.keyframe import Keyframe
from navd.slam.occupancy import OccupancyGrid
from navd.slam.pose_graph import Edge

__all__ = ["MapGraph", "graph_arrays", "graph_from_arrays"]

FloatArray = npt.NDArray[np.float64]
PREFIX = "graph_"  # every array of the graph is named graph_*; a map without one has none


@dataclass(frozen=True, slots=True)
class MapGraph:
    """What a map was built from, besides its grid.

    Attributes:
        keyframes: every keyframe, oldest first (scans are None with loop closure off).
        edges: the pose graph's edges between keyframes (indices into ``keyframes``).
        base: the map the keyframes were drawn over (one loaded without a graph), or None.
    """

    keyframes: tuple[Keyframe, ...]
    edges: tuple[Edge, ...]
    base: OccupancyGrid | None = None


def graph_arrays(graph: MapGraph) -> dict[str, npt.NDArray[np.generic]]:
    """``graph`` as named arrays (all prefixed ``graph_``)."""
    frames = graph.keyframes
    scans = [f.scan for f in frames]
    no_points = np.zeros((0, 2))
    hits = [s.hits if s is not None else no_points for s in scans]
    misses = [s.misses if s is not None else no_points for s in scans]
    views = [
        (s.view.x_m, s.view.y_m, s.view.first_rad, s.view.span_rad) if s is not None else (0,) * 4
        for s in scans
    ]
    edges = graph.edges
    arrays: dict[str, npt.NDArray[np.generic]] = {
        "stamp": np.array([f.stamp for f in frames], dtype=np.float64),
        "pose": np.array([tuple(f.pose) for f in frames], dtype=np.float64).reshape(-1, 3),
        "mapped": np.array([f.mapped for f in frames], dtype=bool),
        "has_scan": np.array([s is not None for s in scans], dtype=bool),
        "hits": np.concatenate([no_points, *hits]).astype(np.float64),
        "hit_end": np.cumsum([h.shape[0] for h in hits], dtype=np.int64),
        "misses": np.concatenate([no_points, *misses]).astype(np.float64),
        "miss_end": np.cumsum([m.shape[0] for m in misses], dtype=np.int64),
        "view": np.array(views, dtype=np.float64).reshape(-1, 4),
        "edge_ij": np.array([(e.i, e.j) for e in edges], dtype=np.int64).reshape(-1, 2),
        "edge_z": np.array([tuple(e.z) for e in edges], dtype=np.float64).reshape(-1, 3),
        "edge_weights": np.array([e.weights for e in edges], dtype=np.float64).reshape(-1, 3),
        "edge_robust": np.array([e.robust for e in edges], dtype=bool),
    }
    if graph.base is not None:
        arrays.update(graph.base.state("base_"))
    return {PREFIX + name: value for name, value in arrays.items()}


def _require_finite(what: str, values: npt.NDArray[np.generic]) -> None:
    """Raise MapFileError if ``values`` (the graph's ``what``) hold NaN or infinity: a scan
    drawn from them could not be placed on the grid."""
    if not np.all(np.isfinite(values)):
        raise MapFileError(f"the map's graph has {what} that are not finite (NaN or inf)")


def graph_from_arrays(data: Mapping[str, npt.NDArray[np.generic]]) -> MapGraph | None:
    """The graph in ``data`` (a state file's arrays), or None if it holds none.

    Raises:
        MapFileError: arrays missing or of sizes that do not agree, named.
    """
    if PREFIX + "pose" not in data:
        return None  # saved without its graph (older navd, or a map from elsewhere)

    def get(name: str) -> npt.NDArray[np.generic]:
        try:
            return np.asarray(data[PREFIX + name])
        except KeyError:
            raise MapFileError(f"the map's graph lacks its {name!r} array") from None

    poses = np.asarray(get("pose"), dtype=np.float64)
    if poses.ndim != 2 or poses.shape[1] != 3:
        raise MapFileError(f"the map's graph has keyframe poses of shape {poses.shape}, not N x 3")
    _require_finite("keyframe poses", poses)
    n = poses.shape[0]
    stamps, mapped, has_scan = get("stamp"), get("mapped"), get("has_scan")
    hit_end, miss_end, view = get("hit_end"), get("miss_end"), get("view")
    hits, misses = np.asarray(get("hits")), np.asarray(get("misses"))
    for name, array in (("stamp", stamps), ("mapped", mapped), ("has_scan", has_scan)):
        if array.shape != (n,):
            raise MapFileError(f"the map's graph has {n} keyframes but {array.shape} {name!r}")
    for name, points in (("hits", hits), ("misses", misses)):
        if points.ndim != 2 or points.shape[1] != 2:
            raise MapFileError(f"the map's graph has {name} of shape {points.shape}, not N x 2")
        _require_finite(name, points)
    if hit_end.shape != (n,) or miss_end.shape != (n,) or view.shape != (n, 4):
        raise MapFileError(f"the map's graph has {n} keyframes but scan offsets that disagree")
    for ends in (hit_end, miss_end):
        if n and (int(ends[0]) < 0 or bool(np.any(np.diff(ends) < 0))):
            raise MapFileError("the map's graph has scan offsets that disagree (not increasing)")
    if (n and (int(hit_end[-1]) != hits.shape[0] or int(miss_end[-1]) != misses.shape[0])) or (
        not n and (hits.shape[0] or misses.shape[0])
    ):
        raise MapFileError("the map's graph has scan points its offsets do not account for")
    frames = []
    hit_start = np.concatenate([[0], hit_end[:-1]]).astype(np.int64)
    miss_start = np.concatenate([[0], miss_end[:-1]]).astype(np.int64)
    for k in range(n):
        scan = None
        if has_scan[k]:
            x, y, first, span = (float(v) for v in view[k])
            scan = ScanPoints(
                hits[hit_start[k] : hit_end[k]].copy(),
                misses[miss_start[k] : miss_end[k]].copy(),
                FieldOfView(x, y, first, span),
            )
        pose = Pose2(*(float(v) for v in poses[k]))
        frames.append(Keyframe(float(stamps[k]), pose, scan, bool(mapped[k])))
    ij, z, weights, robust = get("edge_ij"), get("edge_z"), get("edge_weights"), get("edge_robust")
    m = ij.shape[0]
    if ij.shape != (m, 2) or z.shape != (m, 3) or weights.shape != (m, 3) or robust.shape != (m,):
        raise MapFileError(f"the map's graph has {m} edges but arrays of other sizes")
    if m and (int(ij.min()) < 0 or int(ij.max()) >= n):
        raise MapFileError(f"the map's graph has an edge to a keyframe it does not have ({n})")
    edges = tuple(
        Edge(
            int(ij[e, 0]),
            int(ij[e, 1]),
            Pose2(*(float(v) for v in z[e])),
            (float(weights[e, 0]), float(weights[e, 1]), float(weights[e, 2])),
            bool(robust[e]),
        )
        for e in range(m)
    )
    base = None
    if any(name.startswith(PREFIX + "base_") for name in data):
        try:
            base = OccupancyGrid.from_state(data, PREFIX + "base_")
        except KeyError as err:
            raise MapFileError(f"the map's graph has a base map without its {err} array") from None
        except ValueError as err:
            raise MapFileError(f"the map's graph has a malformed base map: {err}") from err
    return MapGraph(tuple(frames), edges, base)
