"""DON's object regression, region by region: each 8-connected region of a mask of
moving pixels as a line (its principal axis, `component_lines`); how a line relates to
last frame's (`follow`) and to an edge (`lies_along`, `edge_along`, `erase_edges`); and
the square about a pivot that a link can reach (`reach_square`).

Coordinates are working-resolution pixels (x right, y down).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import cv2
import numpy as np

from imimic_gym.estimators.don.compiled import region_moments

__all__ = ["component_lines", "edge_along", "erase_edges", "follow", "lies_along",
           "reach_square"]


def reach_square(pivot: np.ndarray, radius: float) -> tuple[slice, slice]:
    """Row and column slices (working px) of the square about ``pivot`` (x, y) that a
    link of ``radius`` px can reach past `LinkTracker.measure`'s radius gate: 1.6 radii either side,
    clipped at the image's top and left (numpy clips the other two)."""
    reach = 1.6 * radius
    (left, top), (right, bottom) = (np.floor(np.asarray(pivot) - reach).astype(int),
                                    np.ceil(np.asarray(pivot) + reach).astype(int))
    return slice(max(top, 0), max(bottom, 0)), slice(max(left, 0), max(right, 0))


def component_lines(mask: np.ndarray, min_area: int,
                    box: tuple[int, int, int, int] | None = None) -> np.ndarray:
    """Principal axis of every 8-connected component of ``mask`` with at least
    ``min_area`` pixels, from its second moments.

    ``mask``: (h, w) uint8 (or bool), nonzero where a pixel moves.
    ``box``: the bounding box of its nonzero pixels (left, top, width, height), where the
    caller knows it (`don.MotionMask`); else found here.
    Returns (k, 7) float64 rows, in OpenCV's label order: centre x, centre y, direction x,
    direction y, length (std along the axis, px), elongation (major/minor std ratio),
    area (px).
    """
    mask = mask.view(np.uint8)
    left, top, width, height = cv2.boundingRect(mask) if box is None else box
    if width == 0:
        return np.zeros((0, 7))
    # Label only the moving pixels' bounding box, cropped from even coordinates: OpenCV
    # numbers 8-connected components in the raster order of 2x2 blocks, so the crop
    # numbers them exactly as the whole mask would, for a quarter of the pixels.
    right, bottom = left + width, top + height
    left, top = left & ~1, top & ~1
    crop = mask[top:bottom, left:right]
    count, labels = cv2.connectedComponents(crop, connectivity=8)
    # Raw moments per region: sums of x, y, x^2, y^2, xy over its pixels (exact: integers,
    # in any order of summation), in one compiled pass over the labels.
    sums = region_moments(labels, count, float(left), float(top))
    return np.array([_principal_axis(*row) for row in sums[1:].tolist()
                     if row[0] >= max(min_area, 2)]).reshape(-1, 7)


def _principal_axis(n: float, sx: float, sy: float, sxx: float, syy: float,
                    sxy: float) -> tuple[float, ...]:
    """One row of `component_lines` from a region's raw moments (pixel count n, sums of
    x, y, x^2, y^2, xy). Scalar math: a frame has one or two regions, and numpy's
    per-call cost on 1-element arrays is ten times the arithmetic."""
    cx, cy = sx / n, sy / n
    a, c, b = sxx / n - cx * cx, syy / n - cy * cy, sxy / n - cx * cy
    half = (a - c) / 2
    half_gap = math.sqrt(half * half + b * b)
    major, minor = (a + c) / 2 + half_gap, max((a + c) / 2 - half_gap, 1e-9)
    theta = 0.5 * float(np.arctan2(2 * b, a - c))  # math.atan2 differs in the last bit
    return (cx, cy, math.cos(theta), math.sin(theta), math.sqrt(major),
            math.sqrt(major / minor), n)


def follow(line: list[float], previous: list[list[float]], turn_deg: float
            ) -> tuple[int | None, float]:
    """The line of ``previous`` (last frame's) that ``line`` continues, if any, and how
    far (px) it lies across from it: the nearest one (across) nearly parallel to it
    (within ``turn_deg``), of a similar length and overlapping it along the axis. ``line``
    slid sideways from it if that is `TrackerConfig.shift_px` or more. The nearest, not
    any: a turning link's leading sliver has last frame's trailing one parallel beside
    it, one link width away, and last frame's leading one just behind it."""
    # Scalars (rows of `component_lines` as lists): a frame has a few lines, and numpy's
    # per-call cost on arrays that short is many times the arithmetic.
    cx, cy, dx, dy, length = line[:5]
    parallel_sin = math.sin(math.radians(turn_deg))
    nearest, nearest_across = None, math.inf
    for index, (px, py, pdx, pdy, plength, *_) in enumerate(previous):
        ox, oy = px - cx, py - cy
        across = abs(ox * dy - oy * dx)
        if (abs(pdx * dy - pdy * dx) < parallel_sin and 0.7 * length < plength < 1.4 * length
                and across < 3 * length and abs(ox * dx + oy * dy) < 1.7 * length
                and across < nearest_across):
            nearest, nearest_across = index, across
    return nearest, nearest_across


def lies_along(line: list[float], edge: tuple[float, ...], across_px: float = 3.0,
           parallel_sin: float = 0.1) -> bool:
    """Whether ``line`` (a `component_lines` row) lies along ``edge`` (centre x, y,
    direction x, y, length): its centre within ``across_px`` of the edge's axis, its
    direction within ``parallel_sin`` (the sine of the angle; 0.1: about 6 degrees) of
    parallel, and beside the edge rather than beyond its ends."""
    cx, cy, dx, dy, length = edge
    ox, oy = line[0] - cx, line[1] - cy
    return (abs(ox * -dy + oy * dx) < across_px
            and abs(line[2] * dy - line[3] * dx) < parallel_sin
            and abs(ox * dx + oy * dy) < length)


def edge_along(line: list[float], edges: list[tuple[float, ...]], across_px: float,
                parallel_sin: float) -> tuple[float, ...] | None:
    """The first of ``edges`` that ``line`` (a `component_lines` row) lies along by the
    guess's tolerances before the pivot (`lies_along` within ``across_px`` and
    ``parallel_sin``), or None."""
    for edge in edges:
        if lies_along(line, edge, across_px, parallel_sin):
            return edge
    return None


def erase_edges(mask: np.ndarray, edges: Sequence[tuple[float, ...]], width: int
                 ) -> np.ndarray:
    """A copy of ``mask`` with a line ``width`` px wide cleared along each of ``edges`` (centre
    x, y, direction x, y, length), over its 1.7 lengths either side of the centre."""
    cleared = mask.copy()
    for cx, cy, dx, dy, length in edges:
        half = 1.7 * length
        cv2.line(cleared, (round(cx - half * dx), round(cy - half * dy)),
                 (round(cx + half * dx), round(cy + half * dy)), 0, width)
    return cleared
