"""The compiled inner loops against the numpy and OpenCV calls they replace, to the last
bit: DON's estimates stay what they were only if these agree exactly."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest

from imimic_gym.estimators.don.appearance import _match, match_table
from imimic_gym.estimators.don.compiled import (
    best_ray,
    close_colour_mean,
    keep_window_changes,
    pairwise_sum,
    pivot_solve,
    region_moments,
    running_extrema,
)
from imimic_gym.estimators.don.config import AppearanceConfig

COLOUR = AppearanceConfig()  # the appearance layer's defaults
MATCH = match_table(COLOUR.sigma)


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


def _opencv_match(pixels: np.ndarray, colour: tuple[float, ...]) -> np.ndarray:
    """What the appearance layer computed with OpenCV before `colour_match`."""
    return cv2.LUT(cv2.transform(cv2.absdiff(pixels, colour), np.ones((1, 3))), MATCH)


def test_colour_match_is_opencvs_absdiff_sum_and_table_to_the_bit() -> None:
    rng = np.random.default_rng(1)
    for trial in range(200):
        pixels = rng.integers(0, 256, (7, 9, 3), dtype=np.uint8)
        # Halves round to even, and colours past 0-255 saturate per channel, as in OpenCV.
        rgb = np.round(rng.uniform(-40, 300, 3)) + (0.5 if trial % 2 else 0.3)
        colour = (*rgb.tolist(), 0.0)
        np.testing.assert_array_equal(_match(pixels, colour, MATCH), _opencv_match(pixels, colour))


def test_best_ray_picks_the_ray_with_the_colour_and_refuses_a_flat_background() -> None:
    rng = np.random.default_rng(2)
    samples = rng.integers(100, 110, (3 * 20, 14, 3), dtype=np.uint8)  # a grey wall
    colour = (200, 120, 90)
    floors = 255 * COLOUR.min_match, 255 * COLOUR.min_contrast
    assert best_ray(samples, colour, MATCH, 3, *floors) == (-1, -1)
    samples[3 * 7 + 2] = colour  # ray 7, shifted by its third offset, runs along the link
    samples[3 * 7 + 1, :5] = colour
    assert best_ray(samples, colour, MATCH, 3, *floors) == (7, 2)


def test_keep_window_changes_is_layer_3_as_opencv_computed_it() -> None:
    rng = np.random.default_rng(3)
    tau = 8
    for _ in range(50):
        image, previous, low_a, low_b = rng.integers(0, 256, (4, 30, 40, 3), dtype=np.uint8)
        high_a, high_b = np.maximum(low_a, image), np.maximum(low_b, previous)

        def any_channel(difference: np.ndarray) -> np.ndarray:
            return cv2.cvtColor(cv2.threshold(difference, tau, 255, cv2.THRESH_BINARY)[1],
                                cv2.COLOR_RGB2GRAY)

        delta1 = any_channel(cv2.absdiff(image, previous))
        low, high = cv2.min(low_a, low_b), cv2.max(high_a, high_b)
        expected = cv2.bitwise_and(delta1, any_channel(
            cv2.max(cv2.subtract(image, low), cv2.subtract(high, image))))
        left, top, width, height = cv2.boundingRect(delta1)
        count, *box = keep_window_changes(delta1, image, low_a, low_b, high_a, high_b, tau,
                                          top, left, height, width)
        np.testing.assert_array_equal(delta1, expected)
        assert count == cv2.countNonZero(expected)
        assert tuple(box) == cv2.boundingRect(expected)


def test_running_extrema_and_close_colour_mean_match_opencv() -> None:
    rng = np.random.default_rng(4)
    low, high, image = rng.integers(0, 256, (3, 12, 16, 3), dtype=np.uint8)
    new_low, new_high = running_extrema(low, high, image)
    np.testing.assert_array_equal(new_low, cv2.min(low, image))
    np.testing.assert_array_equal(new_high, cv2.max(high, image))
    weight = rng.integers(0, 256, (12, 16), dtype=np.uint8)
    count, *mean = close_colour_mean(image, weight, 94)
    close = cv2.compare(weight, 94, cv2.CMP_GT)
    assert count == cv2.countNonZero(close)
    assert mean == list(cv2.mean(image, mask=close)[:3])  # to the bit: sum times 1 / count
