"""Grid frames on one lattice: the frame of whole cells covering a box, whether a frame lies
on a lattice, where two frames overlap, a fine mask pooled onto coarse cells, and the marked
cells near a pose as points. The layers use them to put the map, the scan obstacles and the
keep-out zones on the frame of each plan."""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from navd.geometry import Pose2
from navd.planning.costmap import GridFrame

__all__ = ["aligned", "cells_near", "cells_of", "overlap", "pooled", "snap", "window_around"]

BoolArray = npt.NDArray[np.bool_]
FloatArray = npt.NDArray[np.float64]


def snap(
    box: tuple[float, float, float, float], res: float, anchor: tuple[float, float]
) -> GridFrame:
    """The frame of whole cells of the lattice through ``anchor`` covering ``box`` [m]
    (x0, y0, x1, y1)."""
    lo_x, lo_y, hi_x, hi_y = box
    ox = anchor[0] + math.floor(round((lo_x - anchor[0]) / res, 6)) * res
    oy = anchor[1] + math.floor(round((lo_y - anchor[1]) / res, 6)) * res
    cols = math.ceil(round((hi_x - ox) / res, 6))
    rows = math.ceil(round((hi_y - oy) / res, 6))
    return GridFrame(res, ox, oy, rows, cols)


def aligned(frame: GridFrame, anchor: tuple[float, float]) -> bool:
    """True if ``frame``'s cells lie on the lattice through ``anchor``."""
    for offset in (frame.origin_x_m - anchor[0], frame.origin_y_m - anchor[1]):
        cells = offset / frame.resolution_m
        if abs(cells - round(cells)) > 1e-6:
            return False
    return True


def overlap(
    outer: GridFrame, inner: GridFrame
) -> tuple[tuple[slice, slice], tuple[slice, slice]] | None:
    """The slices of ``outer`` and of ``inner`` covering the cells both hold (same lattice),
    or None if they share none."""
    r = round((inner.origin_y_m - outer.origin_y_m) / outer.resolution_m)
    c = round((inner.origin_x_m - outer.origin_x_m) / outer.resolution_m)
    r0, c0 = max(r, 0), max(c, 0)
    r1, c1 = min(r + inner.rows, outer.rows), min(c + inner.cols, outer.cols)
    if r1 <= r0 or c1 <= c0:
        return None
    return (slice(r0, r1), slice(c0, c1)), (slice(r0 - r, r1 - r), slice(c0 - c, c1 - c))


def pooled(coarse: GridFrame, k: int, fine: GridFrame, mask: BoolArray) -> BoolArray:
    """``mask`` (on ``fine``, whose lattice has blocks of k x k cells that are ``coarse``'s
    cells) pooled onto ``coarse``: a coarse cell is set if any of its fine cells is."""
    res = fine.resolution_m
    r = round((fine.origin_y_m - coarse.origin_y_m) / res)  # fine cells from coarse's corner
    c = round((fine.origin_x_m - coarse.origin_x_m) / res)
    out = np.zeros(coarse.shape, dtype=np.bool_)
    if not mask.any():
        return out
    # cut to the coarse frame, then pad to whole blocks
    top, left = max(-r, 0), max(-c, 0)
    part = mask[top:, left:]
    r, c = r + top, c + left
    pad_r, pad_c = r % k, c % k
    rows = math.ceil((part.shape[0] + pad_r) / k) * k
    cols = math.ceil((part.shape[1] + pad_c) / k) * k
    padded = np.zeros((rows, cols), dtype=np.bool_)
    padded[pad_r : pad_r + part.shape[0], pad_c : pad_c + part.shape[1]] = part
    blocks: BoolArray = np.asarray(padded.reshape(rows // k, k, cols // k, k).any(axis=(1, 3)))
    br, bc = r // k, c // k
    rr = min(blocks.shape[0], coarse.rows - br)
    cc = min(blocks.shape[1], coarse.cols - bc)
    if rr > 0 and cc > 0:
        out[br : br + rr, bc : bc + cc] = blocks[:rr, :cc]
    return out


def window_around(frame: GridFrame, pose: Pose2, radius_m: float) -> tuple[slice, slice] | None:
    """The cells of ``frame`` in a square of half-size radius_m around pose (None if none)."""
    r0, c0 = frame.cell_of(pose.x - radius_m, pose.y - radius_m)
    r1, c1 = frame.cell_of(pose.x + radius_m, pose.y + radius_m)
    r0, c0 = max(r0, 0), max(c0, 0)
    r1, c1 = min(r1 + 1, frame.rows), min(c1 + 1, frame.cols)
    if r1 <= r0 or c1 <= c0:
        return None
    return slice(r0, r1), slice(c0, c1)


def cells_of(frame: GridFrame, mask: BoolArray, window: tuple[slice, slice]) -> FloatArray:
    """[m] centres of the cells set in ``mask``, the ``window`` of ``frame`` it covers."""
    cells = np.argwhere(mask) + np.array([window[0].start, window[1].start])
    return frame.centers_of(cells.astype(np.int64))


def cells_near(frame: GridFrame, mask: BoolArray, pose: Pose2, radius_m: float) -> FloatArray:
    """[m] centres of the ``mask`` cells within a square of half-size radius_m around pose."""
    window = window_around(frame, pose, radius_m)
    if window is None:
        return np.empty((0, 2))
    return cells_of(frame, mask[window], window)
