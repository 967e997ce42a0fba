"""`EdgeMemory`: where an occluder's edges are, remembered from frame to frame for
`LinkTracker`, so that its link is never read off them.

In: per frame, the `component_lines` rows of the moving regions (x, y, dx, dy, length,
...; working px), which continue a row of the last frame (`regions.follow`), and which
slid sideways. Out: ``expected`` (where the edges that slid lately should be now) and,
before the pivot is found, ``stopped`` (long edges that slid and have since stopped).
Why: `docs/decisions/don-occluder-edges.md`.
"""

from __future__ import annotations

import math

import numpy as np

from imimic_gym.estimators.don.config import TrackerConfig
from imimic_gym.estimators.don.regions import edge_along, lies_along

__all__ = ["EdgeMemory"]

Edge = tuple[float, float, float, float, float]  # centre x, y, direction x, y, length


class EdgeMemory:
    """The sliding and stopped edges of the last frames (`TrackerConfig`'s
    ``edge_memory``, ``guess_edge_length``, ``guess_edge_px``, ``guess_edge_deg``)."""

    def __init__(self, config: TrackerConfig) -> None:
        self.config = config
        self._parallel_sin = math.sin(math.radians(config.guess_edge_deg))
        # Where the edges that slid lately should be in the newest frame; and for the next
        # frame, each with its shift per frame (x, y) and the frames since it was seen.
        self.expected: list[Edge] = []
        self._moving: list[tuple[Edge, tuple[float, float], int]] = []
        # Long edges that slid and have since stopped, as seen in the newest frame;
        # updated only until the pivot is agreed, for `LinkTracker.before_pivot`.
        self.stopped: list[tuple[float, ...]] = []

    def advance(self, rows: list[list[float]], previous: list[int | None],
                sliding: np.ndarray, previous_rows: list[list[float]]) -> None:
        """Move last frame's sliding edges on by their shift into ``expected`` (where
        they should be in this frame), and note this frame's for the next: each sliding
        line (``sliding``, (lines,) bool) with the sideways shift from the line of
        ``previous_rows`` it continues (``previous``, `regions.follow`), and each expected
        edge no sliding line of this frame lies along (merged with the link, say), for up
        to ``edge_memory`` frames."""
        self.expected = [(cx + sx, cy + sy, dx, dy, length) for (
            cx, cy, dx, dy, length), (sx, sy), _ in self._moving]
        slid = [row for row, flag in zip(rows, sliding, strict=True) if flag]
        moving = []
        for edge, (_, shift, unseen) in zip(self.expected, self._moving, strict=True):
            if unseen < self.config.edge_memory and not any(
                    lies_along(row, edge) for row in slid):
                moving.append((edge, shift, unseen + 1))
        for row, k, flag in zip(rows, previous, sliding, strict=True):
            if k is None or not flag:
                continue
            cx, cy, dx, dy, length = row[:5]
            across = ((cx - previous_rows[k][0]) * -dy + (cy - previous_rows[k][1]) * dx)
            moving.append(((cx, cy, dx, dy, length), (-dy * across, dx * across), 0))
        self._moving = moving

    def note_stopped(self, rows: list[list[float]], sliding: np.ndarray) -> None:
        """``stopped``: this frame's regions longer than ``guess_edge_length`` that do not
        slide but lie along (``guess_edge_px``, ``guess_edge_deg``) a long edge that slid
        (``expected``) or one that had stopped in the last frame: a board whose side stops
        sliding stays an edge for the guess before the pivot. Matched with the last
        frame's edge, so a region turning slowly beside it stays one."""
        known = self.guess_edges()
        self.stopped = [
            tuple(row[:5]) for row, flag in zip(rows, sliding, strict=True)
            if not flag and row[4] > self.config.guess_edge_length
            and self.along(row, known)]

    def along(self, line: list[float], edges: list[tuple[float, ...]]
              ) -> tuple[float, ...] | None:
        """`regions.edge_along` by the guess's tolerances (``guess_edge_px``,
        ``guess_edge_deg``)."""
        return edge_along(line, edges, self.config.guess_edge_px, self._parallel_sin)

    def guess_edges(self) -> list[tuple[float, ...]]:
        """The edges no guess before the pivot may lie along: the long ones that slid
        (where they should be now) and the stopped ones."""
        long = self.config.guess_edge_length
        return [edge for edge in self.expected if edge[4] > long] + self.stopped
