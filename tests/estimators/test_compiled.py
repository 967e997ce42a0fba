"""The compiled inner loops against the numpy arithmetic they replace, to the last bit:
DON's estimates stay what they were only if these agree exactly."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest

from imimic_gym.estimators.compiled import pairwise_sum, pivot_solve, region_moments


@pytest.mark.parametrize("n", [1, 7, 8, 9, 15, 16, 127, 128, 129, 200, 256, 780, 1000, 5000])
def test_pairwise_sum_is_numpys_sum_to_the_last_bit(n: int) -> None:
    values = np.random.default_rng(n).random(n) * 1e3
    # 0.1 + 0.2 + ... summed in another order differs in the last bit: the test can fail.
    assert pairwise_sum(values, n) == values.sum()
    assert pairwise_sum(values, n // 2) == values[: n // 2].sum()


def test_region_moments_match_each_labels_pixels() -> None:
    rng = np.random.default_rng(0)
    mask = (rng.random((40, 50)) > 0.7).astype(np.uint8)
    count, labels = cv2.connectedComponents(mask, connectivity=8)
    sums = region_moments(labels, count, 10.0, 20.0)
    assert sums.shape == (count, 6) and not sums[0].any()
    for label in range(1, count):
        ys, xs = np.nonzero(labels == label)
        x, y = xs + 10.0, ys + 20.0
        expected = [len(xs), x.sum(), y.sum(), (x * x).sum(), (y * y).sum(), (x * y).sum()]
        np.testing.assert_array_equal(sums[label], expected)


def _lines_through(pivot: tuple[float, float], angles_deg: np.ndarray) -> np.ndarray:
    """`component_lines` rows of slivers 10 px long whose axes pass through ``pivot``,
    centred 12 px out along each angle (y down)."""
    rad = np.radians(angles_deg)
    dx, dy = np.cos(rad), -np.sin(rad)
    cx, cy = pivot[0] + 12 * dx, pivot[1] + 12 * dy
    ones = np.ones_like(rad)
    return np.column_stack([cx, cy, dx, dy, 10 * ones, 5 * ones, 30 * ones])


def test_pivot_solve_finds_where_the_lines_cross_and_needs_20_pairs() -> None:
    lines = _lines_through((40.0, 30.0), np.linspace(10, 170, 12))
    found, x, y = pivot_solve(lines, math.nan, 0.0, math.nan, 20)
    assert found and math.hypot(x - 40, y - 30) < 1e-9
    # Seven lines 5 degrees apart: only the pairs more than 10 degrees apart count (15).
    found, *_ = pivot_solve(_lines_through((40.0, 30.0), np.arange(7) * 5.0),
                            math.nan, 0.0, math.nan, 20)
    assert not found


def test_pivot_solve_drops_crossings_the_link_could_not_point_from() -> None:
    lines = _lines_through((40.0, 30.0), np.linspace(10, 170, 12))
    # Every line points up from the pivot: a pointing range that only allows down fails.
    assert pivot_solve(lines, math.nan, math.radians(90), math.radians(80), 20)[0]
    assert not pivot_solve(lines, math.nan, math.radians(-90), math.radians(80), 20)[0]
