"""The distance transform against scipy's, cell for cell."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from scipy import ndimage

from navd.planning._distance_kernels import distance_to


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


@pytest.mark.parametrize("shape", [(300, 200), (1, 500), (500, 1)])
def test_sparse_features_on_long_lines(shape: tuple[int, int]) -> None:
    mask = np.random.default_rng(sum(shape)).random(shape) < 0.002
    mask.flat[0] = True  # at least one
    np.testing.assert_array_equal(distance_to(mask), ndimage.distance_transform_edt(~mask))
