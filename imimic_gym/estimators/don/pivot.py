"""The pivot a link turns about, from the lines of its moving regions
(`PivotEstimator`): the mode of their pairwise crossings.

Coordinates are working-resolution pixels (x right, y down); directions rad, CCW with
the image's y axis up. Why it seeks every 3 lines and counts only crossings near which
both regions start: `docs/decisions/don-pivot.md`.
"""

from __future__ import annotations

import math
from collections import deque

import numpy as np

from imimic_gym.estimators.don.compiled import pivot_solve

__all__ = ["PivotEstimator"]


class PivotEstimator:
    """The point where the link's lines meet: the mode of the pairwise intersections of
    the last ``memory`` lines. Lines of the turning link all cross at the pivot; lines of
    anything else (a distractor, a blob elongated along the motion) cross anywhere, so
    they spread out and do not move the mode.

    Until a first pivot is agreed it is solved every ``seek_every`` new lines, and taken
    when two solves in a row agree within ``agree_px`` (a pivot made of a sweeping
    occluder's edges moves with the occluder, the real one stays put). After that it is
    re-solved every ``refine_every`` new lines: the pivot does not move, and a solve
    over all pairs of 40 lines costs as much as the rest of a frame. Every frame
    before a pivot is a guess, so it is sought often (`docs/decisions/don-pivot.md`).

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
