"""Where the moving link is: DON's object regression (a line per moving region), the
pivot, and the link's direction. Shared by DON and the baselines, so every estimator is
compared on the same geometry and differs only in how it finds moving pixels.

All coordinates are working-resolution pixels (x right, y down); directions are radians,
counter-clockwise with the image's y axis pointing up.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Sequence

import cv2
import numpy as np

from imimic_gym.estimators.compiled import pivot_solve, region_moments
from imimic_gym.kinematics import wrap_angle

__all__ = ["LinkTracker", "PivotEstimator", "component_lines", "pointing_range", "within_range"]

# An edge that slid sideways by at least SHIFT_PX while turning less than TURN_DEG since the
# last frame is translating (an occluder's side), not turning about a pivot.
SHIFT_PX, TURN_DEG = 1.5, 2.0
# An edge followed this many frames running (each frame's line parallel to the last's,
# within TURN_DEG) that has turned less than TURN_DEG in all is rigid: an occluder's side
# moving too slowly to slide by SHIFT_PX a frame, or the body swaying; a turning link's
# slivers turn with it.
RIGID_FRAMES = 6
# Re-seeking the pivot: a second estimate, fed with every moving edge that is not sliding
# or rigid, replaces the pivot when it lies RESEEK_PX (working px) or more away and the
# recent lines fan out from it over at least RESEEK_GAIN times as many BEARING_BIN_DEG
# bins of bearing as from the pivot, and at least RESEEK_BINS.
RESEEK_PX, RESEEK_GAIN, RESEEK_BINS, BEARING_BIN_DEG = 6.0, 1.5, 5, 4.0
# The recent lines the two are scored on: twice a pivot estimate's memory. Over 40, a
# few seconds of the body swaying (`exp1-noisy-fast`) made the shoulder outscore a right
# elbow, and the pivot flipped between them (development clips 0-79 and 80-159:
# `exp1-noisy-fast` 13.92 -> 13.44 and 14.16 -> 11.92 deg with 80).
RESEEK_MEMORY = 80
RANGE_MARGIN_DEG = 20.0  # how far past its joint range a region may still be the link
# Seeing past an occluder's edge (`LinkTracker.measure` with a mask): where the link
# touches a sliding edge their pixels merge into one region that lies along no ray. The
# edges that slid last frame, moved on by their last shift (and carried on so for up to
# EDGE_MEMORY frames while merged out of sight), are erased from the mask in a line
# ERASE_PX wide, and what is left within PARALLEL_DEG of parallel to one of them is its
# remnant, not the link.
EDGE_MEMORY, ERASE_PX, PARALLEL_DEG = 6, 3, 10.0
# Before the pivot is agreed, a region within GUESS_EDGE_PX of where such an edge should
# be and within GUESS_EDGE_DEG of parallel to it is that edge (merged with the link,
# perhaps): not the link's axis to guess from (`LinkTracker.before_pivot`). Only edges
# longer (std along the axis, working px) than GUESS_EDGE_LENGTH count: a forearm
# carried sideways by the body's sway slides too, and counting its region (7 px on the
# development clip where it did; a whole 35 px forearm is 10) ruled the forearm itself
# out; a board's side is 14-17. Such an edge that stops sliding is still the board's:
# while a long region that does not slide lies along it (the same distance and angle),
# it stays one for the guess (`LinkTracker.stopped_edges`).
GUESS_EDGE_PX, GUESS_EDGE_DEG, GUESS_EDGE_LENGTH = 8.0, 20.0, 12.0
# Before the pivot, the shortest region (std along its axis, working px: 4 is a region
# 14 px long) whose axis is a guess: the moving clutter's blobs, 2.5-3.3 long, had been
# guessed from and held for a dozen frames, 60-70 degrees off.
GUESS_MIN_LENGTH = 4.0
_GUESS_PARALLEL_SIN = math.sin(math.radians(GUESS_EDGE_DEG))


def pointing_range(base: float, joint_range: tuple[float, float]) -> tuple[float, float]:
    """Where a link can point, as (middle direction, half-width), rad: its joint's range
    (low, high, rad) about its parent's direction ``base`` (rad), widened by
    `RANGE_MARGIN_DEG` either side for a pivot a few pixels off."""
    lo, hi = joint_range
    return base + (lo + hi) / 2, (hi - lo) / 2 + math.radians(RANGE_MARGIN_DEG)


def within_range(q: float, joint_range: tuple[float, float] | None) -> float:
    """The joint angle ``q`` (rad, wrapped to [-pi, pi)) moved to the nearer (round the
    circle) of the joint's limits ``joint_range`` (low, high, rad) where it lies outside
    them; ``q`` itself inside them or without a range. An estimator reads directions
    with a margin past the range (`pointing_range`) and can hold a reading from before
    a pivot was found; the arm itself never passes its limits, so a reported angle past
    one is that much nearer the truth at the limit. DON's settled RMSE on development
    clips, without -> with, seeds 0-79 / 80-159 (`benchmarks/don_dev_seeds.py
    --compare`): `exp3-forearm-high` 7.99 -> 7.95 / 9.08 -> 9.01 deg, `exp1-noisy-fast`
    11.18 -> 11.17 / 8.51 -> 8.46, the other scenarios within 0.01; no clip worse, as
    none can be where the truth keeps within the limits. The baselines report within
    them too."""
    if joint_range is None:
        return q
    lo, hi = joint_range
    if hi - lo >= 2 * math.pi or (q - lo) % (2 * math.pi) <= hi - lo:
        return q
    nearer = lo if abs(wrap_angle(q - lo)) < abs(wrap_angle(q - hi)) else hi
    return float(wrap_angle(nearer))


def reach_square(pivot: np.ndarray, radius: float) -> tuple[slice, slice]:
    """Row and column slices (working px) of the square about ``pivot`` (x, y) that a
    link of ``radius`` px can reach past `measure`'s radius gate: 1.6 radii either side,
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


class PivotEstimator:
    """The point where the link's lines meet: the mode of the pairwise intersections of
    the last ``memory`` lines. Lines of the turning link all cross at the pivot; lines of
    anything else (a distractor, a blob elongated along the motion) cross anywhere, so
    they spread out and do not move the mode.

    Until a first pivot is agreed it is solved every ``seek_every`` new lines, and taken
    when two solves in a row agree within ``agree_px`` (a pivot made of a sweeping
    occluder's edges moves with the occluder, the real one stays put). After that it is
    re-solved every ``refine_every`` new lines: the pivot does not move, and a solve
    over all pairs of 40 lines costs as much as the rest of a frame. Seeking every 3
    lines rather than every 10 agrees a pivot sooner, and every frame before it is a
    guess: on development clips settled RMSE 8.1 -> 5.9 deg on `exp3-forearm-none`, 15.1
    -> 13.1 on `exp3-forearm-low`, 25.6 -> 22.6 on `exp3-forearm-high`, 0.59 -> 0.54 on
    `exp2-servo`, at a cost of 22.3 -> 23.0 on `exp1-noisy-fast`
    (`benchmarks/don_dev_seeds.py`). Requiring instead that a solve agree with one 10
    lines older kept most of the delay (8.5 on `exp3-forearm-none` seeking every line).

    ``directions`` (middle, half-width), rad: where the link can point. A crossing only
    counts if both regions lie, seen from it, within that fan: the link's own regions
    always do about the true pivot, while an occluder's edge crossing the link does so
    by chance.

    ``reach_back`` (px): a crossing only counts if both regions start near it, beyond it:
    neither reaches back past it by more than ``reach_back``, and neither's near end is
    farther from it than its own length (plus 3 px). A turning link's slivers start at
    its pivot. Two crossing in the middle of one (a narrow fan, whose lines meet at
    shallow angles along the link) put the pivot out on the forearm; a forearm's lines
    crossing an occluder's edge far past both ends put it on the person's hip; either
    stayed once agreed. None: no such test (a whole-object mask covers the pivot itself).

    The mean shift toward the mode starts from the densest 9x9 px block of crossings,
    counted, not weighted by the regions' lengths: an occluder's long edges outweighed
    the link's short slivers, and the median of all crossings lay between the clusters.
    """

    def __init__(self, memory: int = 40, seek_every: int = 3, refine_every: int = 20,
                 agree_px: float = 4.0,
                 directions: tuple[float, float] | None = None,
                 reach_back: float | None = None) -> None:
        self.directions, self.reach_back = directions, reach_back
        self.lines: deque[np.ndarray | list[float]] = deque(maxlen=memory)
        self.tracks: deque[int | None] = deque(maxlen=memory)  # each line's edge, if known
        self.seek_every, self.refine_every = seek_every, refine_every
        self.agree_px = agree_px
        self._new, self._stale = 0, False
        self._last: np.ndarray | None = None
        self._candidate: np.ndarray | None = None

    def add_line(self, line: np.ndarray | list[float], track: int | None = None) -> None:
        """``line``: a row of `component_lines` (centre, direction, length, elongation; an
        array or a list);
        ``track``: the edge it was followed along (`LinkTracker`), if any."""
        self.lines.append(line)
        self.tracks.append(track)
        self._new += 1
        if self._new >= (self.seek_every if self._last is None else self.refine_every):
            self._stale, self._new = True, 0

    def withdraw(self, track: int) -> None:
        """Forget every line of edge ``track`` (found rigid: it was never the link)."""
        if track not in self.tracks:
            return
        kept = [(line, t) for line, t in zip(self.lines, self.tracks, strict=True)
                if t != track]
        self.lines = deque((line for line, _ in kept), maxlen=self.lines.maxlen)
        self.tracks = deque((t for _, t in kept), maxlen=self.tracks.maxlen)

    def take_over(self, other: PivotEstimator, pivot: np.ndarray) -> None:
        """Adopt ``other``'s lines and its agreed ``pivot`` (re-seeking, `LinkTracker`)."""
        self.lines, self.tracks = deque(other.lines, maxlen=self.lines.maxlen), deque(
            other.tracks, maxlen=self.tracks.maxlen)
        self._last, self._candidate = pivot.copy(), None
        self._new, self._stale = 0, False

    def provisional(self) -> np.ndarray | None:
        """Before a first pivot is agreed: the last solve's, awaiting the next to agree."""
        return self._candidate if self._last is None else None

    def pivot(self) -> np.ndarray | None:
        """The current pivot (working pixels), or None before a first one is agreed."""
        if not self._stale or len(self.lines) < 12:
            return self._last
        self._stale = False
        point = self._solve()
        if point is None:
            return self._last
        if self._last is None:
            candidate, self._candidate = self._candidate, point
            if candidate is None or np.hypot(*(point - candidate)) > self.agree_px:
                return None
        self._last = point
        return point

    def _solve(self) -> np.ndarray | None:
        """The densest point of the intersections of line pairs that cross at more than
        10 degrees (mean shift from their densest block), if at least 20 such pairs
        exist (`compiled.pivot_solve`)."""
        reach_back = math.nan if self.reach_back is None else self.reach_back
        middle, half_width = (0.0, math.nan) if self.directions is None else self.directions
        found, x, y = pivot_solve(np.array(self.lines), reach_back, middle, half_width, 20)
        return np.array([x, y]) if found else None


def _follow(line: list[float], previous: list[list[float]]) -> tuple[int | None, float]:
    """The line of ``previous`` (last frame's) that ``line`` continues, if any, and how
    far (px) it lies across from it: the nearest one (across) nearly parallel to it
    (within TURN_DEG), of a similar length and overlapping it along the axis. ``line`` slid
    sideways from it if that is SHIFT_PX or more. The nearest, not any: a turning link's
    leading sliver has last frame's trailing one parallel beside it, one link width away,
    and last frame's leading one just behind it."""
    # Scalars (rows of `component_lines` as lists): a frame has a few lines, and numpy's
    # per-call cost on arrays that short is many times the arithmetic.
    cx, cy, dx, dy, length = line[:5]
    parallel_sin = math.sin(math.radians(TURN_DEG))
    nearest, nearest_across = None, math.inf
    for index, (px, py, pdx, pdy, plength, *_) in enumerate(previous):
        ox, oy = px - cx, py - cy
        across = abs(ox * dy - oy * dx)
        if (abs(pdx * dy - pdy * dx) < parallel_sin and 0.7 * length < plength < 1.4 * length
                and across < 3 * length and abs(ox * dx + oy * dy) < 1.7 * length
                and across < nearest_across):
            nearest, nearest_across = index, across
    return nearest, nearest_across


def _along(line: list[float], edge: tuple[float, ...], across_px: float = 3.0,
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


def _edge_along(line: list[float], edges: list[tuple[float, ...]]
                ) -> tuple[float, ...] | None:
    """The first of ``edges`` that ``line`` (a `component_lines` row) lies along by the
    guess's tolerances before the pivot (`_along` within GUESS_EDGE_PX and
    GUESS_EDGE_DEG of parallel), or None."""
    for edge in edges:
        if _along(line, edge, GUESS_EDGE_PX, _GUESS_PARALLEL_SIN):
            return edge
    return None


def _erase_edges(mask: np.ndarray, edges: Sequence[tuple[float, ...]]) -> np.ndarray:
    """A copy of ``mask`` with a line ERASE_PX wide cleared along each of ``edges`` (centre
    x, y, direction x, y, length), over its 1.7 lengths either side of the centre."""
    cleared = mask.copy()
    for cx, cy, dx, dy, length in edges:
        half = 1.7 * length
        cv2.line(cleared, (round(cx - half * dx), round(cy - half * dy)),
                 (round(cx + half * dx), round(cy + half * dy)), 0, ERASE_PX)
    return cleared


class LinkTracker:
    """Follows one link turning about a fixed pivot, from masks of moving pixels.

    Args:
        reference_direction: direction (rad) of the fixed reference link.
        pivot: the pivot (working pixels), if known; else estimated from the masks.
        joint_range: the joint's (low, high) limits (rad), if known.
        min_area: fewest pixels a moving region needs to count.
        reach_back: how far (px) a region may reach back past the pivot and still be the
            link; None: any. Frame differences of a turning link are slivers that start
            at the pivot, so DON sets it; a whole-object mask (MOG2, CamShift) covers
            the link's rounded end around the pivot, and its extent along the axis is
            only estimated, so the baselines leave it off.
        seek_every: new lines between pivot solves until one is agreed
            (`PivotEstimator`). DON seeks every 3; the baselines every 10: agreeing that
            soon on their whole-object masks' axes locked a worse pivot (development
            clips 0-9, MOG2 settled RMSE: `exp2-servo` 4.0 against 1.1 deg, and worse on
            each of the six scenarios).
        reseek: follow each moving edge from frame to frame, leave rigid ones
            (`RIGID_FRAMES`) out of the pivot and the link, and replace an agreed pivot
            that a second estimate explains worse (below). DON sets it; the baselines'
            whole-object masks have no edges to follow.

    Re-seeking (``reseek``). A pivot, once agreed, was kept for good, and the first one
    agreed is the one most often wrong: on development clips of `exp3-forearm-high` the
    final pivot was over 15 input px from the elbow on 14 of 80 clips, mostly at a bottom
    corner of the board, where the extensions of its slowly moving sides cross the
    forearm's lines. Two changes. (1) An edge that stays parallel to itself for
    RIGID_FRAMES frames is not a turning link: its lines leave the pivot estimate (all of
    them, back to where it was first seen) and are not read as the link. (2) A second
    `PivotEstimator` takes every non-sliding, non-rigid edge, before the pivot is agreed
    and after (the first then takes only the link's), and is solved once the first has
    agreed; where its pivot lies RESEEK_PX or more from the current one, the two are
    scored, once per solve, on the last RESEEK_MEMORY such lines: over how many
    BEARING_BIN_DEG bins of bearing the lines lying along rays from the point (as
    `measure` accepts them, without the radius and last-direction gates) fan out. A
    turning link's lines fan out from its pivot; a still edge's, or a board side's, all
    point one way. The second replaces the first when it scores RESEEK_GAIN times as
    high and at least RESEEK_BINS. Chosen on development seeds 0-79 and checked on
    80-159 (`benchmarks/don_dev_seeds.py --compare`): see `don.py` for the figures.
    """

    def __init__(self, reference_direction: float = 0.0, pivot: np.ndarray | None = None,
                 joint_range: tuple[float, float] | None = None, min_area: int = 12,
                 reach_back: float | None = None, seek_every: int = 3,
                 reseek: bool = False) -> None:
        self.reference_direction, self.known_pivot = reference_direction, pivot
        self.joint_range, self.min_area = joint_range, min_area
        self.reach_back = reach_back
        # Where the link can point: (middle direction, half-width) in rad, the joint's
        # range plus a margin for a pivot a few pixels off.
        self.directions = (None if joint_range is None
                           else pointing_range(reference_direction, joint_range))
        self.pivots = PivotEstimator(directions=self.directions, reach_back=reach_back,
                                     seek_every=seek_every)
        self._previous_lines = np.zeros((0, 7))
        self._previous_rows: list[list[float]] = []  # the same, as lists
        self.sliding = np.zeros(0, dtype=bool)  # per line of the last `lines` call
        self._slid = np.zeros(0, dtype=bool)  # slid since the frame before, per line
        self.radius: float | None = None
        self._radius_pivot: np.ndarray | None = None
        self.lost_for = 0
        self.reseek = reseek and pivot is None
        # Per line of the last `lines` call: (edge id, its direction (dx, dy) when first
        # seen, frames followed).
        self._edges: list[tuple[int, float, float, int]] = []
        self._edge_count = 0
        self._shadow = PivotEstimator(directions=self.directions, reach_back=reach_back,
                                      seek_every=seek_every)
        self._recent: deque[list[float]] = deque(maxlen=RESEEK_MEMORY)
        self._compared: np.ndarray | None = None  # the second estimate's last solve weighed
        self.reseeks = 0  # how often the pivot was replaced
        # Where the edges that slid lately should be in the newest frame: (centre x, y,
        # direction x, y, length) rows like `component_lines`'; and for the next frame,
        # each with its shift per frame (x, y) and the frames since it was last seen.
        self.expected_edges: list[tuple[float, float, float, float, float]] = []
        self._moving_edges: list[tuple[tuple[float, float, float, float, float],
                                       tuple[float, float], int]] = []
        # Long edges that slid and have since stopped, as seen in the newest frame (same
        # rows); updated only until the pivot is agreed, for `before_pivot`.
        self.stopped_edges: list[tuple[float, ...]] = []

    def pivot(self) -> np.ndarray | None:
        """The pivot in working pixels: the known one, else the estimate (None until the
        estimate is agreed)."""
        return self.known_pivot if self.known_pivot is not None else self.pivots.pivot()

    def lines(self, mask: np.ndarray, box: tuple[int, int, int, int] | None = None
              ) -> np.ndarray:
        """The moving regions' lines (`component_lines`; ``box`` the bounding box of
        ``mask``'s pixels, if known). Until a pivot is found every elongated region feeds
        the pivot estimate; after that only regions accepted as the link do (in
        `measure`), so a distractor or an occluder's edges cannot drag a pivot that the
        link's own lines have fixed."""
        lines = component_lines(mask, self.min_area, box)
        # An edge slid sideways (an occluder's side) when it did so in two frames running:
        # once can be the chance shape of a turning link's merged slivers.
        rows = lines.tolist()  # scalars from here: a frame has a few lines
        follows = [_follow(row, self._previous_rows) for row in rows]
        slid = [k if across > SHIFT_PX else None for k, across in follows]
        self.sliding = np.array([k is not None and bool(self._slid[k]) for k in slid], bool)
        self._slid = np.array([k is not None for k in slid], bool)
        edges: Sequence[int | None] = [None] * len(lines)
        if self.reseek:
            edges = self._follow_edges(rows, [k for k, _ in follows])
        # Elongated, not sliding (nor rigid): what a pivot estimate may take.
        feeds = [row[5] > 1.4 and row[4] > 3.0 and not sliding
                 for row, sliding in zip(rows, self.sliding.tolist(), strict=True)]
        if self.known_pivot is None and self.pivots.pivot() is None:
            for row, feed, edge in zip(rows, feeds, edges, strict=True):
                if feed:
                    self.pivots.add_line(row, edge)
        if self.reseek:
            self._seek_again(rows, feeds, edges)
        self._expect_edges(rows, [k for k, _ in follows])
        pivot = self.pivot()
        if pivot is None:
            self._note_stopped_edges(rows)
        self._previous_lines, self._previous_rows = lines, rows
        if pivot is not None and (self._radius_pivot is None
                                  or np.hypot(*(pivot - self._radius_pivot)) > 2.0):
            self.radius, self._radius_pivot = None, pivot  # r was measured from elsewhere
        return lines

    def _expect_edges(self, rows: list[list[float]], previous: list[int | None]) -> None:
        """Move last frame's sliding edges on by their shift into ``expected_edges`` (where
        they should be in this frame), and note this frame's for the next: each sliding
        line with the sideways shift from the line it continues (``previous``,
        `_follow`), and each expected edge no sliding line of this frame lies along
        (merged with the link, say), for up to EDGE_MEMORY frames."""
        self.expected_edges = [(cx + sx, cy + sy, dx, dy, length) for (
            cx, cy, dx, dy, length), (sx, sy), _ in self._moving_edges]
        sliding = [row for row, flag in zip(rows, self.sliding, strict=True) if flag]
        moving = []
        for edge, (_, shift, unseen) in zip(self.expected_edges, self._moving_edges,
                                            strict=True):
            if unseen < EDGE_MEMORY and not any(_along(row, edge) for row in sliding):
                moving.append((edge, shift, unseen + 1))
        for row, k, flag in zip(rows, previous, self.sliding, strict=True):
            if k is None or not flag:
                continue
            cx, cy, dx, dy, length = row[:5]
            across = ((cx - self._previous_rows[k][0]) * -dy
                      + (cy - self._previous_rows[k][1]) * dx)
            moving.append(((cx, cy, dx, dy, length), (-dy * across, dx * across), 0))
        self._moving_edges = moving

    def _note_stopped_edges(self, rows: list[list[float]]) -> None:
        """``stopped_edges``: this frame's long regions that do not slide but lie along
        (`GUESS_EDGE_PX`, `GUESS_EDGE_DEG`) a long edge that slid (``expected_edges``) or
        one that had stopped in the last frame: a board whose side stops sliding.

        The guess before the pivot skipped regions along a sliding edge only, and an
        edge is expected for EDGE_MEMORY frames after it last slid. A board that
        stopped for longer left its still sides in the masks (the body's sway and the
        board's own slow creep keep them moving), the longest regions there, and the
        guess held one, 66 degrees off, for 27 frames on development clip 1 of
        `exp3-forearm-high`. Development clips, settled RMSE, without -> with (seeds
        0-79 chosen, 80-159 a check; `benchmarks/don_dev_seeds.py --compare`):
        `exp3-forearm-low` 7.05 -> 6.23 deg (better on 17 clips, worse on none) /
        7.60 -> 7.27 (5 better, 3 worse; 95% interval of the change -0.80 to -0.00),
        `exp3-forearm-high` 11.79 -> 11.43 (10 better, 1 worse; clip 1 29.3 -> 10.6) /
        12.67 -> 12.66; `exp2-servo` unchanged / 0.46 -> 0.48 (a long side of the
        servo's horn slid, then its still region was skipped: two clips 0.7 -> 1.2 and
        0.3 -> 0.6); the other scenarios unchanged. Matching at the tighter 3 px and 6
        degrees of `_along`'s default lost a board's side that stepped 4 px (high -0.06,
        low -0.28 on 0-79).

        A stopped edge is matched with the last frame's, not with the edge that first
        slid, so a long region that turns under GUESS_EDGE_DEG a frame beside it stays
        one. Only regions longer than GUESS_EDGE_LENGTH count, which a forearm alone is
        not, so on the rendered clips that is a board's side or a blob merged with one.
        Matching each with the first edge's direction instead, and erasing the stopped
        edges too before `before_pivot` looks again, were within noise on development
        clips 0-79 (high -0.03 / -0.06, low +0.09 / +0.01; one clip of low 6.9 -> 14.4
        with the first), so not taken.

        The baselines (`baselines.py`) guess through `before_pivot` too, so this moved
        them as well (held-out settled RMSE, MOG2: `exp2-servo` 2.41 -> 2.59,
        `exp3-forearm-low` 22.68 -> 22.15; CamShift within 0.3)."""
        known = self._guess_edges()
        self.stopped_edges = [
            tuple(row[:5]) for row, sliding in zip(rows, self.sliding, strict=True)
            if not sliding and row[4] > GUESS_EDGE_LENGTH and _edge_along(row, known)]

    def _guess_edges(self) -> list[tuple[float, ...]]:
        """The edges no guess before the pivot may lie along: the long ones that slid
        (where they should be now) and the stopped ones."""
        return ([edge for edge in self.expected_edges if edge[4] > GUESS_EDGE_LENGTH]
                + self.stopped_edges)

    def _follow_edges(self, rows: list[list[float]], previous: list[int | None]
                      ) -> list[int]:
        """Each line's edge id, carried on from the line of the last frame it continues
        (``previous``, `_follow`), else new. A rigid edge (`RIGID_FRAMES`) joins the
        sliding ones in ``self.sliding`` and leaves both pivot estimates."""
        edges = []
        for index, (line, k) in enumerate(zip(rows, previous, strict=True)):
            if k is None:
                self._edge_count += 1
                edges.append((self._edge_count, line[2], line[3], 1))
            else:
                edge, dx, dy, frames = self._edges[k]
                edges.append((edge, dx, dy, frames + 1))
            edge, dx, dy, frames = edges[-1]
            turned = abs(dx * line[3] - dy * line[2])  # sin of the turn since first seen
            if frames >= RIGID_FRAMES and turned < math.sin(math.radians(TURN_DEG)):
                self.sliding[index] = True
                self.pivots.withdraw(edge)
                self._shadow.withdraw(edge)
        self._edges = edges
        return [edge for edge, *_ in edges]

    def _seek_again(self, rows: list[list[float]], feeds: list[bool],
                    edges: Sequence[int | None]) -> None:
        """Feed the second pivot estimate the lines that may feed one (``feeds``) and
        replace the pivot where it explains the recent lines better (see the class
        docstring)."""
        for row, feed, edge in zip(rows, feeds, edges, strict=True):
            if feed:
                self._shadow.add_line(row, edge)
                self._recent.append(row)
        current = self.pivots.pivot()
        if current is None:  # until then the second estimate sees the first's lines
            return
        candidate = self._shadow.pivot()
        # Once per solve of the second estimate (it returns the same array until then).
        if candidate is None or candidate is self._compared:
            return
        self._compared = candidate
        if np.hypot(*(candidate - current)) < RESEEK_PX:
            return
        if self._fan(candidate) >= max(RESEEK_BINS, RESEEK_GAIN * self._fan(current)):
            self.pivots.take_over(self._shadow, candidate)
            self.reseeks += 1

    def _fan(self, point: np.ndarray) -> int:
        """Over how many BEARING_BIN_DEG bins of bearing from ``point`` the recent lines
        that lie along rays from it (`_on_ray`) spread."""
        px, py = float(point[0]), float(point[1])
        bins = set()
        for cx, cy, dx, dy, length, _, _ in self._recent:
            ray = self._on_ray(px, py, cx, cy, dx, dy, length)
            if ray is not None:
                bins.add(math.floor(math.degrees(ray[1]) / BEARING_BIN_DEG))
        return len(bins)

    def _on_ray(self, px: float, py: float, cx: float, cy: float, dx: float, dy: float,
                length: float) -> tuple[float, float] | None:
        """The region centred at (cx, cy) with axis (dx, dy) and ``length`` (a
        `component_lines` row) seen from a pivot at (px, py): its distance (px) and
        bearing (rad, CCW, image up) if it lies along a ray from the pivot (within ~14
        degrees), does not reach back past it by more than ``reach_back``, and lies where
        the link can point; else None. `measure`'s gates that do not depend on the last
        frames."""
        ox, oy = cx - px, cy - py
        distance = float(np.hypot(ox, oy))
        if not (abs(ox * dy - oy * dx) < max(4.0, 0.25 * distance) and distance > 2.0):
            return None
        # A sliver of a turning link starts at its pivot: one reaching back past it (an
        # occluder's edge sweeping across the joint) is something else.
        if self.reach_back is not None and not distance - 1.7 * length > -self.reach_back:
            return None
        bearing = float(np.arctan2(-oy, ox))  # image y points down
        # The link cannot point where its joint cannot turn: an occluder's edge or a
        # flipped reading there is not the link.
        if self.directions is not None and not abs(
                wrap_angle(bearing - self.directions[0])) < self.directions[1]:
            return None
        return distance, bearing

    def _sliding(self, lines: np.ndarray) -> np.ndarray:
        """Which of ``lines`` slid sideways in the last two frames (`_follow`; or are rigid): the
        flags `lines` computed, if these are its lines; else none."""
        return self.sliding if lines is self._previous_lines else np.zeros(len(lines), bool)

    def measure(
        self, lines: np.ndarray, pivot: np.ndarray, last: float | None,
        mask: np.ndarray | None = None,
    ) -> tuple[float, float] | None:
        """The location s: the link's direction (rad, CCW, image up), from the moving
        regions that lie along a ray from the pivot, and the link's visible length (px):
        how far from the pivot the outermost region's tip reaches (a region's half-length
        is 1.7 standard deviations along its axis, as for a uniform bar). Not the span
        from the innermost region's inner end: next to the pivot the link barely moves,
        so where its slivers begin flickers from frame to frame, and a clear link read
        as 85-90% visible.

        A region belongs to the link when it is clearly elongated and its principal axis
        points at the pivot within ~14 degrees (it lies along a ray: the link's leading and
        trailing slivers do, a distractor's blob seldom does), it does not reach back past
        the pivot by more than ``reach_back`` px (an occluder's edge sweeping across the
        joint does), it is no farther
        than 1.6 link radii, it lies where the joint can turn (its range, if known, plus
        20 degrees) and so does its axis, and within 45 degrees of the last direction.
        The axis test matters next to the pivot: a region centred a few pixels from it
        passes the ray test whatever its axis (the test allows 4 px across), and pointed
        outward from a centre just inside the range its axis can point anywhere. Without
        it, development clip 45 of `exp3-forearm-none` read the forearm straight down, 180
        degrees off, for three frames (settled RMSE 27.1 -> 3.9 deg with it). Settled RMSE
        on development clips, without -> with, seeds 0-79 / 80-159
        (`benchmarks/don_dev_seeds.py --compare`): `exp3-forearm-none` 2.37 -> 2.08 / 2.41
        -> 2.41, `exp3-forearm-high` 7.99 -> 7.99 / 9.39 -> 9.08 (clip 85 27.4 -> 9.4),
        the other scenarios within 0.01; no clip worse. The radius and direction
        gates are both dropped after 5 frames without a match, so neither a wrong lock nor
        a radius measured on a stray early region can last. The direction is the
        mean of those regions' axes weighted by length times area, pointed away from the
        pivot: an axis does not tilt when the pivot is a few pixels off, as a
        pivot-to-pixel angle would.

        ``mask``: the (h, w) mask ``lines`` came from. Where no region is the link, the
        link may have merged with an occluder's sliding edge into one region along no
        ray: the regions are found again with the edges expected in this frame erased
        from it (`EDGE_MEMORY`). On development clips 0-19 of `exp3-forearm-high`, 48% of
        the squared error was in frames where DON held a link it had called hidden, 392
        of those 942 frames with no occlusion at all; on seed 13 the forearm, in full
        view, swung past the board's edge at frame 123 and DON held 33.5 degrees to the
        clip's end, up to 75 degrees off. `don.py` gives the figures.
        """
        px, py = float(pivot[0]), float(pivot[1])
        kept = self._link_regions(lines, px, py, last)
        if not kept and mask is not None and self.expected_edges:
            lines = self._past_edges(mask)
            kept = self._link_regions(lines, px, py, last)
        if not kept:
            self.lost_for += 1
            return None
        self.lost_for = 0
        if self.known_pivot is None and self.pivots.pivot() is not None:
            edges = ([edge for edge, *_ in self._edges] if self.reseek
                     and lines is self._previous_lines else [None] * len(lines))
            for index, *_ in kept:
                self.pivots.add_line(lines[index], edges[index])
        mean = math.atan2(sum(weight * math.sin(angle) for _, angle, weight, _, _ in kept),
                          sum(weight * math.cos(angle) for _, angle, weight, _, _ in kept))
        reach = max(distance + 1.7 * length for *_, distance, length in kept)
        self.radius = reach if self.radius is None else 0.9 * self.radius + 0.1 * reach
        return mean, reach

    def _past_edges(self, mask: np.ndarray, parallel_deg: float = PARALLEL_DEG
                    ) -> np.ndarray:
        """The lines of ``mask`` with the expected occluder edges erased from it, less
        those within ``parallel_deg`` of parallel to one of them (what is left of it)."""
        lines = component_lines(_erase_edges(mask, self.expected_edges), self.min_area)
        if len(lines):
            keep = np.ones(len(lines), bool)
            parallel_sin = math.sin(math.radians(parallel_deg))
            for _, _, dx, dy, _ in self.expected_edges:
                keep &= np.abs(lines[:, 2] * dy - lines[:, 3] * dx) > parallel_sin
            lines = lines[keep]
        return lines

    def _link_regions(self, lines: np.ndarray, px: float, py: float, last: float | None
                      ) -> list[tuple[int, float, float, float, float]]:
        """`measure`'s regions of the link among ``lines``, about the pivot (px, py):
        (index, outward direction (rad), weight, distance from the pivot, length)."""
        # Region by region in scalars: a frame has a few regions, and numpy's per-call cost
        # on arrays that short was most of this method's time. Square roots and arctangents
        # stay numpy's: math's differ from them in the last bit.
        gated = self.lost_for < 5  # the radius and direction gates
        kept = []
        sliding = self._sliding(lines)
        for index, (cx, cy, dx, dy, length, elongation, area) in enumerate(lines.tolist()):
            if sliding[index]:  # an occluder's side, not a turning link
                continue
            # Clearly elongated: a round blob (a ball, a fist turning) says nothing about a
            # direction. Then along a ray from the pivot, where the link can point.
            if not (length > 2.5 and elongation > 2.0):
                continue
            ray = self._on_ray(px, py, cx, cy, dx, dy, length)
            if ray is None:
                continue
            distance, centre_angle = ray
            if self.radius is not None and gated and not distance < 1.6 * self.radius:
                continue
            if last is not None and gated and not abs(
                    wrap_angle(centre_angle - last)) < math.radians(45):
                continue
            # Axes point from the pivot outward; y flips to the CCW, image-up convention.
            ox, oy = cx - px, cy - py
            if dx * ox + dy * oy < 0:
                dx, dy = -dx, -dy
            axis = float(np.arctan2(-dy, dx))
            # The axis too where the link can point (see `measure`).
            if self.directions is not None and not abs(
                    wrap_angle(axis - self.directions[0])) < self.directions[1]:
                continue
            kept.append((index, axis, length * area, distance, length))
        return kept

    def before_pivot(self, lines: np.ndarray, mask: np.ndarray | None = None
                     ) -> tuple[float, float] | None:
        """Until the pivot is found: the longest elongated region's axis (rad), pointed
        by the joint range, and that region's extent along it (px: 3.4 standard
        deviations, the span `measure` takes a region to cover); None without a range or
        such a region.

        ``mask``: the (h, w) mask ``lines`` came from. Where no region gives a guess, the
        forearm may have merged with a board's sliding side into one blob too round to
        guess from: the regions are found again with the edges expected in this frame
        erased (as `measure` does after the pivot), leaving out what is left within
        GUESS_EDGE_DEG of parallel to one of them (`measure`'s PARALLEL_DEG let the
        remnants of a board's corner through: on development clip 16 of
        `exp3-forearm-high` a guess 80 degrees off held for 16 frames). Development
        clips, settled RMSE, without -> with, seeds 0-79 (chosen) / 80-159 (a check;
        `benchmarks/don_dev_seeds.py --compare`): `exp3-forearm-high` 11.43 -> 10.82 deg
        (27 clips better, 2 worse; 95% interval of the change -0.94 to -0.33) / 12.66 ->
        12.26 (22 better, 4 worse; -0.83 to +0.04), `exp3-forearm-low` 6.23 -> 6.12 (16
        better, 4 worse) / 7.27 -> 6.93 (15 better, 1 worse; -0.60 to -0.14),
        `exp3-forearm-none` unchanged / 2.93 -> 2.91, the other scenarios unchanged.
        The baselines pass no mask, so this look past the edges is DON's alone.

        Not a short region (`GUESS_MIN_LENGTH`; development clips 0-39, settled RMSE
        with 2.5 -> 4: `exp3-forearm-high` 13.68 -> 12.59 deg, `exp3-forearm-low` 7.64 ->
        6.47, `exp3-forearm-none` 2.64 -> 2.52, `exp1-noisy-fast` 14.39 -> 14.20; 3.5,
        4.5 and 5.5 within 0.4 of it, 7 worse). Seeds 0-79 / 80-159: `exp3-forearm-high`
        13.13 -> 11.79 / 13.86 -> 12.67 (95% interval of the change on 80-159 -2.0 to
        -0.5), `exp3-forearm-low` 7.91 -> 7.05 / 8.31 -> 7.60 (-1.3 to -0.2),
        `exp3-forearm-none` 3.59 -> 3.52 / 2.87 -> 2.93 (-0.2 to +0.3; one clip 4.0 ->
        11.8), `exp1-noisy-fast` 13.44 -> 13.26 / 11.75 -> 11.56, `default` within 0.01,
        `exp2-servo` unchanged.

        Not a sliding edge, nor a region along where a long one should be now
        (`GUESS_EDGE_PX`) or has stopped (`stopped_edges`): a board's side merged with
        the forearm, no longer parallel enough to its last self to be followed, was the
        longest region, and the guess held its direction, over 70 degrees off, until the
        next one (development clips 0-39, settled RMSE: `exp3-forearm-high` 15.17 ->
        13.68 deg, `exp3-forearm-low` 9.79 -> 7.64, `exp3-forearm-none` 2.64 -> 2.64.
        Counting edges of any length: within 8 px and 20 degrees none 2.66, as the
        forearm's own region, slid with the body, ruled the forearm out; within 3 px and
        6 degrees high 14.68, low 9.19; within 12 px 13.88 and 7.03 but none 2.75).
        Seeds 0-79 / 80-159: `exp3-forearm-high` 14.29 -> 13.13 / 14.58 -> 13.86 (95%
        interval of the change on 80-159 -1.4 to -0.1), `exp3-forearm-low` 9.20 -> 7.91
        / 9.20 -> 8.31 (-1.5 to -0.3); no clip of the other scenarios changed. The
        baselines guess here too, so both changes moved them as well (held-out settled
        RMSE, MOG2: `exp3-forearm-low` 24.0 -> 22.7, `-high` 25.7 -> 24.2, `-none` 12.4
        -> 11.2; CamShift within 0.2)."""
        guess = self._axis_guess(lines)
        if guess is None and mask is not None and self.expected_edges:
            guess = self._axis_guess(self._past_edges(mask, GUESS_EDGE_DEG))
        return guess

    def _axis_guess(self, lines: np.ndarray) -> tuple[float, float] | None:
        """`before_pivot` from ``lines`` alone."""
        if self.directions is None or len(lines) == 0:
            return None
        candidates = lines[(lines[:, 5] > 2.0) & (lines[:, 4] > GUESS_MIN_LENGTH)
                           & ~self._sliding(lines)]
        edges = self._guess_edges()
        if len(candidates) and edges:
            candidates = candidates[[_edge_along(row, edges) is None
                                     for row in candidates.tolist()]]
        if len(candidates) == 0:
            return None
        line = candidates[np.argmax(candidates[:, 4] * candidates[:, 6])]
        axis = math.atan2(-line[3], line[2])  # CCW, image up
        middle, _ = self.directions
        if abs(wrap_angle(axis - middle)) > math.pi / 2:
            axis += math.pi
        return float(wrap_angle(axis)), 3.4 * float(line[4])

    def reach_box(self) -> tuple[slice, slice]:
        """Row and column slices (working px) of the square around the pivot that the
        radius gate lets the link reach (1.6 radii); everything before both are known."""
        pivot = self.pivot()
        if pivot is None or self.radius is None:
            return slice(None), slice(None)
        return reach_square(pivot, self.radius)

    def keypoints(self, angle: float, scale: float = 1.0) -> np.ndarray | None:
        """(2, 2) pixels of the pivot and the link's tip, once both are known: working
        pixels times ``scale`` (input pixels per working pixel gives input pixels)."""
        pivot = self.pivot()
        if pivot is None or self.radius is None:
            return None
        px, py = float(pivot[0]), float(pivot[1])
        tip_x, tip_y = px + self.radius * math.cos(angle), py - self.radius * math.sin(angle)
        return np.array([[px * scale, py * scale], [tip_x * scale, tip_y * scale]])

