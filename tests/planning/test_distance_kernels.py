"""The distance transform against scipy's, cell for cell; the pair and nearest-point
searches against brute force."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from scipy import ndimage

from navd.planning._distance_kernels import any_within, distance_to, nearest_on_polyline


@settings(max_examples=300, deadline=None)
@given(
    arrays(
        np.bool_,
        st.tuples(st.integers(1, 40), st.integers(1, 40)),
        elements=st.booleans() | st.just(False),
    )
)
def test_equals_scipys_exact_transform(mask: np.ndarray) -> None:
    got = distance_to(mask)
    if not mask.any():
        assert np.isinf(got).all()  # nothing to be near
    else:
        np.testing.assert_array_equal(got, ndimage.distance_transform_edt(~mask))


@pytest.mark.parametrize("shape", [(0, 5), (5, 0), (0, 0)])
def test_an_empty_grid_gives_an_empty_grid(shape: tuple[int, int]) -> None:
    mask = np.zeros(shape, dtype=np.bool_)
    assert distance_to(mask).shape == shape
    # The kernel's own code run by Python checks every index: no write past the grid.
    assert distance_to.py_func(mask).shape == shape


@pytest.mark.parametrize("shape", [(300, 200), (1, 500), (500, 1)])
def test_sparse_features_on_long_lines(shape: tuple[int, int]) -> None:
    mask = np.random.default_rng(sum(shape)).random(shape) < 0.002
    mask.flat[0] = True  # at least one
    np.testing.assert_array_equal(distance_to(mask), ndimage.distance_transform_edt(~mask))


points = arrays(
    np.float64,
    st.tuples(st.integers(0, 12), st.just(2)),
    elements=st.floats(-3.0, 3.0, allow_nan=False),
)


@settings(max_examples=300, deadline=None)
@given(points, points, st.floats(0.0, 2.0))
def test_any_within_agrees_with_every_pair_compared(
    a: np.ndarray, b: np.ndarray, radius: float
) -> None:
    pairs = ((a[:, None, :] - b[None, :, :]) ** 2).sum(axis=2) if a.size and b.size else []
    assert any_within(a, b, radius) == bool(np.any(np.asarray(pairs) < radius**2))


def test_any_within_is_strict_at_the_radius() -> None:
    a = np.array([[0.0, 0.0]])
    assert not any_within(a, np.array([[0.5, 0.0]]), 0.5)
    assert any_within(a, np.array([[0.4999, 0.0], [9.0, 9.0]]), 0.5)


# on a 0.1 m lattice: a segment is a point or at least 0.1 m long (a route's steps are cells)
polylines = arrays(
    np.float64,
    st.tuples(st.integers(2, 10), st.just(2)),
    elements=st.integers(-30, 30).map(lambda v: v / 10.0),
)


@settings(max_examples=300, deadline=None)
@given(polylines, st.floats(-4.0, 4.0), st.floats(-4.0, 4.0), st.integers(0, 8))
def test_nearest_on_polyline_is_on_it_and_nothing_sampled_is_nearer(
    line: np.ndarray, x: float, y: float, first: int
) -> None:
    first = min(first, line.shape[0] - 2)
    segment, t, d = nearest_on_polyline(line, first, x, y)
    assert first <= segment <= line.shape[0] - 2
    assert 0.0 <= t <= 1.0
    a, b = line[segment], line[segment + 1]
    assert d == pytest.approx(np.hypot(*(a + t * (b - a) - (x, y))), abs=1e-9)
    # 201 points along every segment from ``first`` on: none nearer (segments before it
    # are not searched)
    s = np.linspace(0.0, 1.0, 201)[:, None]
    for i in range(first, line.shape[0] - 1):
        along = line[i] + s * (line[i + 1] - line[i])
        assert np.hypot(along[:, 0] - x, along[:, 1] - y).min() >= d - 1e-9


def test_nearest_on_polyline_takes_the_first_of_equally_near_segments() -> None:
    # a route out along x and back: both legs pass (1, 0) at the same distance
    line = np.array([[0.0, 0.0], [2.0, 0.0], [0.0, 0.0]])
    assert nearest_on_polyline(line, 0, 1.0, 0.5) == (0, 0.5, 0.5)
    assert nearest_on_polyline(line, 1, 1.0, 0.5) == (1, 0.5, 0.5)
