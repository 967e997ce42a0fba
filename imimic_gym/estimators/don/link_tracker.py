"""`LinkTracker`: one link turning about a pivot, followed from masks of moving pixels.

In: per frame, a (h, w) uint8 mask of moving pixels (DON's l_1, or a baseline's
foreground). Out: the lines of its regions (`component_lines`), the pivot
(`PivotEstimator`), and the link's direction s (rad, CCW, image up) with its visible
length (px) about that pivot (`measure`; before the pivot, `before_pivot`). This is the
paper's object regression and location for one link (§3); the paper never says how the
pivot is found. Shared by DON and the baselines, so every estimator is compared on the
same geometry and differs only in how it finds moving pixels.

Coordinates are working-resolution pixels (x right, y down). The rules that keep an
occluder's edges out: `docs/decisions/don-pivot.md`, `don-occluder-edges.md`.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Sequence

import numpy as np

from imimic_gym.estimators.don.config import TrackerConfig
from imimic_gym.estimators.don.edge_memory import EdgeMemory
from imimic_gym.estimators.don.pivot import PivotEstimator
from imimic_gym.estimators.don.regions import (
    component_lines,
    erase_edges,
    follow,
    reach_square,
)
from imimic_gym.estimators.joint_range import pointing_range
from imimic_gym.kinematics import wrap_angle

__all__ = ["LinkTracker"]


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
            the link's rounded end around the pivot, so the baselines leave it off.
        seek_every: new lines between pivot solves until one is agreed
            (`PivotEstimator`): DON 3, the baselines 10 (`docs/decisions/don-pivot.md`).
        reseek: follow each moving edge from frame to frame, leave rigid ones out of the
            pivot and the link, and replace an agreed pivot that a second estimate
            explains worse. DON sets it; the baselines' whole-object masks have no edges
            to follow.
        config: the thresholds (`TrackerConfig`).

    Re-seeking (``reseek``): an edge that stays parallel to itself for ``rigid_frames``
    is not a turning link, so its lines leave the pivot estimate and are not read as the
    link. A second `PivotEstimator` takes every non-sliding, non-rigid edge; where its
    pivot lies ``reseek_px`` or more from the current one, both are scored on the last
    ``reseek_memory`` lines by how many ``bearing_bin_deg`` bins of bearing the lines
    lying along rays from them fan out over (`_fan`): a turning link's lines fan out from
    its pivot, a still edge's all point one way. The second replaces the first when it
    scores ``reseek_gain`` times as high and at least ``reseek_bins``.
    """

    def __init__(self, reference_direction: float = 0.0, pivot: np.ndarray | None = None,
                 joint_range: tuple[float, float] | None = None, min_area: int = 12,
                 reach_back: float | None = None, seek_every: int = 3,
                 reseek: bool = False, config: TrackerConfig | None = None) -> None:
        config = TrackerConfig() if config is None else config
        self.config = config
        self.reference_direction, self.known_pivot = reference_direction, pivot
        self.joint_range, self.min_area = joint_range, min_area
        self.reach_back = reach_back
        # Where the link can point: (middle direction, half-width) in rad, the joint's
        # range plus a margin for a pivot a few pixels off.
        self.directions = (None if joint_range is None
                           else pointing_range(reference_direction, joint_range,
                                               config.range_margin_deg))
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
        self._recent: deque[list[float]] = deque(maxlen=config.reseek_memory)
        self._compared: np.ndarray | None = None  # the second estimate's last solve weighed
        self.reseeks = 0  # how often the pivot was replaced
        self.edges = EdgeMemory(config)  # the occluder's edges, remembered

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
        follows = [follow(row, self._previous_rows, self.config.turn_deg) for row in rows]
        slid = [k if across > self.config.shift_px else None for k, across in follows]
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
        self.edges.advance(rows, [k for k, _ in follows], self.sliding, self._previous_rows)
        pivot = self.pivot()
        if pivot is None:
            self.edges.note_stopped(rows, self.sliding)
        self._previous_lines, self._previous_rows = lines, rows
        if pivot is not None and (self._radius_pivot is None
                                  or np.hypot(*(pivot - self._radius_pivot)) > 2.0):
            self.radius, self._radius_pivot = None, pivot  # r was measured from elsewhere
        return lines

    def _follow_edges(self, rows: list[list[float]], previous: list[int | None]
                      ) -> list[int]:
        """Each line's edge id, carried on from the line of the last frame it continues
        (``previous``, `follow`), else new. A rigid edge (``rigid_frames``) joins the
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
            if (frames >= self.config.rigid_frames
                    and turned < math.sin(math.radians(self.config.turn_deg))):
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
        if np.hypot(*(candidate - current)) < self.config.reseek_px:
            return
        if self._fan(candidate) >= max(self.config.reseek_bins,
                                       self.config.reseek_gain * self._fan(current)):
            self.pivots.take_over(self._shadow, candidate)
            self.reseeks += 1

    def _fan(self, point: np.ndarray) -> int:
        """Over how many ``bearing_bin_deg`` bins of bearing from ``point`` the recent lines
        that lie along rays from it (`_on_ray`) spread."""
        px, py = float(point[0]), float(point[1])
        bins = set()
        for cx, cy, dx, dy, length, _, _ in self._recent:
            ray = self._on_ray(px, py, cx, cy, dx, dy, length)
            if ray is not None:
                bins.add(math.floor(math.degrees(ray[1]) / self.config.bearing_bin_deg))
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
        """Which of ``lines`` slid sideways in the last two frames (`follow`; or are rigid): the
        flags `lines` computed, if these are its lines; else none."""
        return self.sliding if lines is self._previous_lines else np.zeros(len(lines), bool)

    def measure(
        self, lines: np.ndarray, pivot: np.ndarray, last: float | None,
        mask: np.ndarray | None = None,
    ) -> tuple[float, float] | None:
        """DON's location s (paper §3) about ``pivot`` (working px): (direction, visible
        length), or None where no region is the link.

        The direction (rad, CCW, image up) is the mean axis, pointed away from the pivot
        and weighted by length times area, of the regions that are the link: clearly
        elongated, lying along a ray from the pivot (within ~14 degrees), reaching back
        past it by at most ``reach_back`` px, no farther than 1.6 link radii, within
        45 degrees of ``last`` (rad), and lying and pointing where the joint can turn
        (its range plus ``range_margin_deg``). The radius and ``last`` gates are dropped
        after 5 frames without a match, so a wrong lock cannot last. The visible length
        (px; M_p of the trust factor) is how far the outermost region's tip reaches, a
        region's half-length being 1.7 standard deviations along its axis (a uniform
        bar); it also updates the link's radius. Axes, not pivot-to-pixel angles: an
        axis does not tilt when the pivot is a few pixels off.

        ``mask``: the (h, w) mask ``lines`` came from. Where no region is the link, the
        link may have merged with an occluder's sliding edge into one region along no
        ray: the regions are found again with the edges expected in this frame erased
        (`docs/decisions/don-occluder-edges.md`, as is the axis test).
        """
        px, py = float(pivot[0]), float(pivot[1])
        kept = self._link_regions(lines, px, py, last)
        if not kept and mask is not None and self.edges.expected:
            lines = self._past_edges(mask, self.config.parallel_deg)
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

    def _past_edges(self, mask: np.ndarray, parallel_deg: float) -> np.ndarray:
        """The lines of ``mask`` with the expected occluder edges erased from it, less
        those within ``parallel_deg`` of parallel to one of them (what is left of it)."""
        lines = component_lines(erase_edges(mask, self.edges.expected, self.config.erase_px),
                                self.min_area)
        if len(lines):
            keep = np.ones(len(lines), bool)
            parallel_sin = math.sin(math.radians(parallel_deg))
            for _, _, dx, dy, _ in self.edges.expected:
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
        such a region. Not a region shorter than ``guess_min_length``, nor a sliding
        edge, nor one along where a long edge should be now or has stopped
        (``guess_edge_px``, ``guess_edge_deg``; `EdgeMemory.stopped`).

        ``mask``: the (h, w) mask ``lines`` came from. Where no region gives a guess, the
        forearm may have merged with a board's sliding side into one blob too round to
        guess from: the regions are found again with the expected edges erased, leaving
        out what lies within ``guess_edge_deg`` of parallel to one of them. The baselines
        pass no mask, so this look past the edges is DON's alone
        (`docs/decisions/don-occluder-edges.md`)."""
        guess = self._axis_guess(lines)
        if guess is None and mask is not None and self.edges.expected:
            guess = self._axis_guess(self._past_edges(mask, self.config.guess_edge_deg))
        return guess

    def _axis_guess(self, lines: np.ndarray) -> tuple[float, float] | None:
        """`before_pivot` from ``lines`` alone."""
        if self.directions is None or len(lines) == 0:
            return None
        candidates = lines[(lines[:, 5] > 2.0) & (lines[:, 4] > self.config.guess_min_length)
                           & ~self._sliding(lines)]
        edges = self.edges.guess_edges()
        if len(candidates) and edges:
            candidates = candidates[[self.edges.along(row, edges) is None
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

