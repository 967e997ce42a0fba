"""DON's per-frame inner loops, compiled with numba: the pivot solve and the regions'
moments (`regions.py`), layer 3 and the window's running extrema (`one_link.py`), and the
appearance layer's colour match, choice of ray and colour-learning mean (`appearance.py`).

DON spent most of a frame at 240x320 not in OpenCV's work but in the interpreter, issuing a
few hundred numpy and OpenCV calls on arrays of a few hundred elements, where each call's
fixed cost is most of its time (benchmarks/RESULTS.md, "What made DON faster"). Each loop
here replaces such a run of calls with one compiled call. It computes exactly what the
calls it replaces computed: the same operations on the same values in the same order
(numpy's pairwise summation and OpenCV's rounding included), so every estimate is
bit-identical (`benchmarks/don_same_estimates.py`; tests/estimators/don/test_compiled.py holds
each loop to the calls it replaced).

Compiled on first use and cached on disk beside this file (numba's ``cache=True``; a
read-only install falls back to numba's user cache), so only the first process pays for the
compilation.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

__all__ = ["GREY_OF_CHANNELS", "best_ray", "close_colour_mean", "colour_match",
           "keep_window_changes", "pairwise_sum", "pivot_solve", "region_moments",
           "running_extrema"]

_SIN_10_DEG = math.sin(math.radians(10))


@njit(cache=True)
def _block_sum(values: np.ndarray, first: int, n: int) -> float:
    """numpy's sum of a block of at most 128 values: sequential under 8, else eight
    running sums combined pairwise, then the remainder."""
    if n < 8:
        total = 0.0
        for k in range(first, first + n):
            total += values[k]
        return total
    r = values[first:first + 8].copy()
    end = first + n - n % 8
    for k in range(first + 8, end, 8):
        for m in range(8):
            r[m] += values[k + m]
    total = ((r[0] + r[1]) + (r[2] + r[3])) + ((r[4] + r[5]) + (r[6] + r[7]))
    for k in range(end, first + n):
        total += values[k]
    return total


@njit(cache=True)
def pairwise_sum(values: np.ndarray, n: int) -> float:
    """Sum of ``values[:n]`` (float64) in numpy's order for a contiguous 1-d sum: blocks
    of at most 128 (`_block_sum`), halved (at a multiple of 8) until they are, and the
    halves' sums added, so that the result is numpy's to the last bit. The halving runs
    on an explicit stack: the recursive version, loaded from numba's cache, failed to link
    ("unresolved symbol")."""
    firsts = np.empty(64, dtype=np.int64)
    sizes = np.empty(64, dtype=np.int64)
    split = np.zeros(64, dtype=np.bool_)
    sums = np.empty(64)
    firsts[0], sizes[0], top, done = 0, n, 1, 0
    while top > 0:
        first, size = firsts[top - 1], sizes[top - 1]
        if size <= 128:
            sums[done] = _block_sum(values, first, size)
            done += 1
            top -= 1
        elif not split[top - 1]:
            split[top - 1] = True
            half = size // 2
            half -= half % 8
            # The second half below the first, so the first is summed first.
            firsts[top], sizes[top], split[top] = first + half, size - half, False
            firsts[top + 1], sizes[top + 1], split[top + 1] = first, half, False
            top += 2
        else:
            sums[done - 2] = sums[done - 2] + sums[done - 1]
            done -= 1
            top -= 1
    return sums[0]


@njit(cache=True)
def region_moments(labels: np.ndarray, count: int, left: float, top: float) -> np.ndarray:
    """Pixel count and raw moments of every label of ``labels`` ((h, w) int32, 0 the
    background, as `cv2.connectedComponents` numbers them), with (``left``, ``top``) added
    to the pixels' x and y: (count, 6) float64 rows n, sum x, sum y, sum x^2, sum y^2,
    sum xy. Integer-valued sums, exact in float64 for any image (under 2^53), so their
    order does not matter."""
    sums = np.zeros((count, 6))
    rows, cols = labels.shape
    for r in range(rows):
        y = r + top
        for c in range(cols):
            label = labels[r, c]
            if label == 0:
                continue
            x = c + left
            row = sums[label]
            row[0] += 1.0
            row[1] += x
            row[2] += y
            row[3] += x * x
            row[4] += y * y
            row[5] += x * y
    return sums


@njit(cache=True)
def _wrap(angle: float) -> float:
    return (angle + math.pi) % (2 * math.pi) - math.pi


@njit(cache=True)
def _densest(xs: np.ndarray, ys: np.ndarray, cell: float) -> tuple[float, float]:
    """`pivot.PivotEstimator`'s start of the mean shift: the centre of the 3x3 block
    of ``cell`` px cells holding the most points; among equal counts the block with the
    smallest key (column << 21 + row), as numpy's unique-then-argmax picks."""
    n = len(xs)
    voted = np.empty(9 * n, dtype=np.int64)
    for k in range(n):
        key = (np.int64(math.floor(xs[k] / cell)) << 21) + np.int64(math.floor(ys[k] / cell))
        m = 0
        for di in (-1, 0, 1):
            for dj in (-1, 0, 1):
                voted[9 * k + m] = key + (np.int64(di) << 21) + dj
                m += 1
    voted.sort()
    best, best_count, run = voted[0], 0, 0
    for k in range(len(voted)):
        run = run + 1 if k > 0 and voted[k] == voted[k - 1] else 1
        if run > best_count:
            best, best_count = voted[k], run
    column = (best + (1 << 20)) >> 21
    return (column + 0.5) * cell, (best - (column << 21) + 0.5) * cell


@njit(cache=True)
def pivot_solve(lines: np.ndarray, reach_back: float, middle: float, half_width: float,
                min_pairs: int) -> tuple[bool, float, float]:
    """`pivot.PivotEstimator._solve` on ``lines`` ((n, 7) `component_lines` rows):
    (found, x, y). ``reach_back`` NaN: no reach test; ``half_width`` NaN: no direction
    test. The pairs run in ``np.triu_indices`` order, as the numpy version's did."""
    n = len(lines)
    total = n * (n - 1) // 2
    pi_ = np.empty(total, dtype=np.int64)
    pj = np.empty(total, dtype=np.int64)
    cross = np.empty(total)
    kept = 0
    for i in range(n):
        for j in range(i + 1, n):
            c = lines[i, 2] * lines[j, 3] - lines[i, 3] * lines[j, 2]
            if abs(c) > _SIN_10_DEG:
                pi_[kept], pj[kept], cross[kept] = i, j, c
                kept += 1
    if kept < min_pairs:
        return False, 0.0, 0.0
    xs = np.empty(kept)
    ys = np.empty(kept)
    weights = np.empty(kept)
    found = 0
    check_reach = not math.isnan(reach_back)
    check_directions = not math.isnan(half_width)
    reached = 0
    for k in range(kept):
        i, j, c = pi_[k], pj[k], cross[k]
        # The crossing is at centre_i + along_i * direction_i = centre_j + along_j * ...
        dx, dy = lines[j, 0] - lines[i, 0], lines[j, 1] - lines[i, 1]
        along_i = (dx * lines[j, 3] - dy * lines[j, 2]) / c
        if check_reach:
            # Both regions must start near the crossing, beyond it: the gap from the
            # crossing to a region's near end is over -reach_back and under its length.
            along_j = (dx * lines[i, 3] - dy * lines[i, 2]) / c
            ok = True
            for line, along in ((i, along_i), (j, along_j)):
                gap = abs(along) - 1.7 * lines[line, 4]
                ok = ok and gap > -reach_back and gap < 3.4 * lines[line, 4] + 3.0
            if not ok:
                continue
        reached += 1
        x = lines[i, 0] + along_i * lines[i, 2]
        y = lines[i, 1] + along_i * lines[i, 3]
        if check_directions:
            # Both regions must lie, seen from the crossing, where the link can point.
            ok = True
            for line in (i, j):
                bearing = math.atan2(-(lines[line, 1] - y), lines[line, 0] - x)
                ok = ok and abs(_wrap(bearing - middle)) < half_width
            if not ok:
                continue
        xs[found], ys[found], weights[found] = x, y, lines[i, 4] * lines[j, 4]
        found += 1
    if reached < min_pairs or found < min_pairs:
        return False, 0.0, 0.0
    xs, ys, weights = xs[:found], ys[:found], weights[:found]
    px, py = _densest(xs, ys, 3.0)
    near = np.empty(found)
    for radius in (16.0, 8.0, 4.0, 4.0):  # shrinking mean shift toward the mode
        count = 0
        sx = sy = 0.0
        for k in range(found):
            if math.hypot(xs[k] - px, ys[k] - py) < radius:
                # numpy summed the (k, 2) products row after row (axis 0) ...
                sx += xs[k] * weights[k]
                sy += ys[k] * weights[k]
                near[count] = weights[k]
                count += 1
        if count == 0:
            break
        # ... and the weights pairwise (a contiguous 1-d sum)
        total_weight = pairwise_sum(near, count)
        px, py = sx / total_weight, sy / total_weight
    return True, px, py


@njit(cache=True)
def colour_match(pixels: np.ndarray, colour: tuple[int, int, int],
                 table: np.ndarray) -> np.ndarray:
    """Per-pixel match (0-255 uint8, (h, w)) of ``pixels`` ((h, w, 3) uint8) with
    ``colour`` (RGB, already rounded to integers as OpenCV rounds a scalar): ``table``
    indexed by the summed absolute difference, each channel's and the sum saturated at
    255. What
    ``cv2.LUT(cv2.transform(cv2.absdiff(pixels, colour), ones((1, 3))), table)`` gives,
    in one pass instead of three."""
    rows, cols = pixels.shape[0], pixels.shape[1]
    out = np.empty((rows, cols), dtype=np.uint8)
    r, g, b = colour
    for i in range(rows):
        for j in range(cols):
            total = (min(abs(np.int64(pixels[i, j, 0]) - r), 255)
                     + min(abs(np.int64(pixels[i, j, 1]) - g), 255)
                     + min(abs(np.int64(pixels[i, j, 2]) - b), 255))
            out[i, j] = table[min(total, 255)]
    return out


@njit(cache=True)
def best_ray(samples: np.ndarray, colour: tuple[int, int, int], table: np.ndarray,
             offsets: int, min_match: float, min_contrast: float) -> tuple[int, int]:
    """`appearance.LinkAppearance`'s choice among rays: ``samples`` ((rays * offsets,
    points, 3) uint8, row ``offsets * k + j`` ray k shifted sideways by its j-th offset)
    are matched with ``colour`` (`colour_match`); a row's score is its mean match (float32,
    as ``cv2.reduce(..., cv2.REDUCE_AVG, dtype=cv2.CV_32F)`` computes it), a ray's the
    best of its rows. Returns (ray, offset) of the best score (the first on a tie), or
    (-1, -1) where it is under ``min_match`` or beats the rays' lower quartile by less
    than ``min_contrast`` (both 0-255; the comparison in float32, as numpy did it)."""
    rows, points = samples.shape[0], samples.shape[1]
    match = colour_match(samples, colour, table)
    scale = np.float32(1.0 / points)
    n = rows // offsets
    scores = np.empty(n, dtype=np.float32)
    sides = np.empty(n, dtype=np.int64)
    for k in range(n):
        for j in range(offsets):
            total = 0
            for p in range(points):
                total += np.int64(match[offsets * k + j, p])
            mean = np.float32(total) * scale
            if j == 0 or mean > scores[k]:
                scores[k], sides[k] = mean, j
    best = 0
    for k in range(1, n):
        if scores[k] > scores[best]:
            best = k
    quartile = np.sort(scores)[n // 4]
    if (scores[best] < np.float32(min_match)
            or np.float32(scores[best] - quartile) < np.float32(min_contrast)):
        return -1, -1
    return best, sides[best]


# cv2.cvtColor(RGB -> grey) of a pixel whose channels are 0 or 255, by which of them are
# 255 (bit 0 red, 1 green, 2 blue): OpenCV's fixed-point weights 4899, 9617, 1868 / 2^14.
GREY_OF_CHANNELS = np.array([(255 * (4899 * (k & 1) + 9617 * (k >> 1 & 1) + 1868 * (k >> 2))
                              + (1 << 13)) >> 14 for k in range(8)], dtype=np.uint8)


@njit(cache=True)
def keep_window_changes(delta1: np.ndarray, image: np.ndarray, low_a: np.ndarray,
                        low_b: np.ndarray, high_a: np.ndarray, high_b: np.ndarray, tau: int,
                        top: int, left: int, height: int, width: int
                        ) -> tuple[int, int, int, int, int]:
    """DON layer 3 in place on ``delta1`` ((h, w) uint8), within its bounding box (``top``,
    ``left``, ``height``, ``width``): l_1 = delta1 & union(delta2), where a pixel of
    ``image`` ((h, w, 3) uint8) is in the union when a channel rises more than ``tau``
    above the window's minimum (the lesser of ``low_a`` and ``low_b``) or falls more than
    ``tau`` below its maximum (the greater of ``high_a`` and ``high_b``). As
    `don.MotionMask` did it with OpenCV, the union is the grey value
    (`GREY_OF_CHANNELS`) of a pixel whose passing channels are 255, and l_1 the bitwise
    and of the two masks' values. (So a pixel whose masks pass in channels whose grey
    values share no bit, blue alone (29) against red and green (226), is dropped; kept so
    that the estimates stay what they were.)

    Returns l_1's pixel count and bounding box (left, top, width, height; zeros where it
    is empty), as ``cv2.countNonZero`` and ``cv2.boundingRect`` would give them."""
    count, x0, y0, x1, y1 = 0, left + width, top + height, -1, -1
    for i in range(top, top + height):
        for j in range(left, left + width):
            if delta1[i, j] == 0:
                continue
            differs = 0
            for c in range(3):
                value = np.int32(image[i, j, c])
                low = np.int32(min(low_a[i, j, c], low_b[i, j, c]))
                high = np.int32(max(high_a[i, j, c], high_b[i, j, c]))
                if value - low > tau or high - value > tau:
                    differs |= 1 << c
            delta1[i, j] &= GREY_OF_CHANNELS[differs]
            if delta1[i, j] != 0:
                count += 1
                x0, x1, y0, y1 = min(x0, j), max(x1, j), min(y0, i), max(y1, i)
    if count == 0:
        return 0, 0, 0, 0, 0
    return count, x0, y0, x1 - x0 + 1, y1 - y0 + 1


@njit(cache=True)
def running_extrema(low: np.ndarray, high: np.ndarray, image: np.ndarray
                    ) -> tuple[np.ndarray, np.ndarray]:
    """New arrays: the elementwise minimum of ``low`` and ``image`` and maximum of
    ``high`` and ``image`` (all the same shape, uint8, C-contiguous). Into fresh arrays,
    each in its own loop: then the compiler knows nothing aliases and vectorises."""
    a, b, x = low.ravel(), high.ravel(), image.ravel()
    new_low, new_high = np.empty_like(a), np.empty_like(b)
    for k in range(x.size):
        new_low[k] = min(a[k], x[k])
    for k in range(x.size):
        new_high[k] = max(b[k], x[k])
    return new_low.reshape(image.shape), new_high.reshape(image.shape)


@njit(cache=True)
def close_colour_mean(patch: np.ndarray, weight: np.ndarray, above: int
                      ) -> tuple[int, float, float, float]:
    """How many pixels of ``weight`` ((h, w) uint8) exceed ``above``, and the mean RGB of
    ``patch`` ((h, w, 3) uint8) over them, as ``cv2.mean(patch, mask=...)`` computes it (the
    sum times the reciprocal of the count); zeros where there are none."""
    count = 0
    sums = np.zeros(3)
    for i in range(weight.shape[0]):
        for j in range(weight.shape[1]):
            if weight[i, j] > above:
                count += 1
                for c in range(3):
                    sums[c] += patch[i, j, c]
    if count == 0:
        return 0, 0.0, 0.0, 0.0
    scale = 1.0 / count
    return count, sums[0] * scale, sums[1] * scale, sums[2] * scale
