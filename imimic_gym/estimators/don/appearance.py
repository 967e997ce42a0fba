"""DON's appearance layer (ours, not the paper's): the link's direction in the current
frame from its colour, once the motion layers have found the pivot and the link.

In: the working frame ((h, w, 3) uint8), the pivot (2,) and radius (working px), and
DON's reading of the frame (direction, rad, CCW with the image's y axis up; whether the
motion layers read it; eta). Out: the link's direction (rad), or None where its colour
is not seen. The colour is learned from readings DON vouches for (eta at least
``vouch_trust``) or from proposals that agree; the search runs rays about the pivot near
DON's reading (or this layer's own track), and the direction is a line fitted to the
matching pixels of a corridor about the best ray. Frame differences see a link only
where it moves; the link itself is in every frame, one colour along its length. Why
each rule and value: `docs/decisions/don-appearance.md`. It cannot fix a wrong pivot
(the rays start there) or a link hidden for longer than its track lasts.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from collections import deque
from typing import Any

import cv2
import numpy as np

from imimic_gym.estimators.don.compiled import best_ray, close_colour_mean, colour_match
from imimic_gym.estimators.don.config import AppearanceConfig
from imimic_gym.estimators.don.regions import reach_square
from imimic_gym.kinematics import wrap_angle

__all__ = ["LinkAppearance", "match_table"]



@functools.lru_cache(maxsize=8)
def match_table(sigma: float) -> np.ndarray:
    """(256,) uint8: the match (0-255) of a summed absolute RGB difference (0-255,
    saturated), exp(-(d / sigma)^2), and none under 0.1."""
    table = 255 * np.exp(-(np.arange(256) / sigma) ** 2)
    return np.where(table < 25.5, 0, np.round(table)).astype(np.uint8)


def _match(colours: np.ndarray, colour: tuple[float, ...], table: np.ndarray) -> np.ndarray:
    """Per-pixel match (0-255 uint8, (h, w)) of (h, w, 3) uint8 colours with ``colour``."""
    return colour_match(colours, _rounded(colour), table)


def _rounded(colour: tuple[float, ...]) -> tuple[int, int, int]:
    """``colour``'s RGB as the integers a match compares with: rounded half to even
    (Python's round, as OpenCV rounds a scalar against uint8 pixels)."""
    r, g, b = (round(c) for c in colour[:3])
    return r, g, b


class LinkAppearance:
    """Reads one link's direction from its colour, about a pivot found elsewhere.

    Directions are radians, counter-clockwise with the image's y axis up; coordinates
    are working-resolution pixels (x right, y down), as in `link_tracker.py`.

    Args:
        config: every setting (`AppearanceConfig`): ``disagree_deg`` is how far this
            layer's reading may lie from a vouched one before the frame counts against the
            colour (``relearn`` such frames running and it is learned anew; ``math.inf``:
            only vouched frames without a reading count, for a caller whose vouched
            readings are often off by more, `LinkedDON`); a first colour matching more
            than ``max_share`` of the square the link can reach is not learned (None: any
            is); from ``first_trust`` (below ``vouch_trust``) a reading proposes a first
            colour, learned once ``first_agree`` proposals agree (None: only vouched
            readings teach it).
        **fields: `AppearanceConfig` fields replaced (``LinkAppearance(max_share=None)``).
    """

    def __init__(self, config: AppearanceConfig | None = None, **fields: Any) -> None:
        config = dataclasses.replace(config or AppearanceConfig(), **fields)
        self.config = config
        self.step = math.radians(config.step_deg)
        self.turns = round(360.0 / config.step_deg)  # grid steps in a turn
        self.disagree, self.agree = math.radians(config.disagree_deg), math.radians(
            config.agree_deg)
        self.max_share, self.first_trust = config.max_share, config.first_trust
        self.offsets = np.array(config.offsets)
        start, stop, count = config.fractions
        self.fractions = np.linspace(start, stop, count)
        self.table = match_table(config.sigma)
        self.reset()

    def reset(self) -> None:
        self.colour: tuple[float, ...] | None = None  # RGB (and a 0 for OpenCV's scalar)
        self.last: float | None = None  # the last frame's reading, rad (None: no reading)
        self.turn = 0.0  # how far the link turned between the last two readings, rad
        self.disagreed = 0  # vouched frames running that this layer read otherwise or not
        # First colours proposed by readings DON trusts less than it vouches (RGB, 0).
        self.proposals: deque[tuple[float, ...]] = deque(maxlen=self.config.proposals)
        self._rays: tuple[np.ndarray, np.ndarray] | None = None  # sample maps, cached
        self._rays_for: tuple[float, float, float] | None = None  # pivot x, y, radius

    def update(self, image: np.ndarray, pivot: np.ndarray, radius: float, prior: float,
               read: bool, trust: float, directions: tuple[float, float] | None = None,
               lost: bool = False) -> float | None:
        """The link's direction (rad) in ``image`` ((h, w, 3) uint8, the working frame),
        or None where its colour is not seen (or not yet learned).

        Args:
            pivot: (2,) the link's pivot, working px.
            radius: the link's length from the pivot, working px.
            prior: DON's direction for this frame, rad.
            read: DON's motion layers read the link in this frame (``prior`` is that
                reading, not a held or predicted one).
            trust: DON's eta for the frame.
            directions: (middle, half-width), rad, where the link can point; None: anywhere.
            lost: the caller has lost the link (`DON.hidden`): without a track of its own,
                this layer searches everywhere the link can point, not nowhere.

        A colour that fails ``relearn`` vouched frames running (no reading, or one more than
        ``disagree`` from DON's) was learned from something else: it is dropped and learned
        again from the next vouched frame.
        """
        vouched = read and trust >= self.config.vouch_trust
        if self.colour is None:  # no reading in this frame, even if it teaches the colour
            angle = None
            if vouched or (read and self.first_trust is not None
                           and trust >= self.first_trust):
                self._learn_first(image, pivot, radius, prior, vouched)
        else:
            angle = self._read(image, self.colour, pivot, radius, prior, vouched,
                               directions, lost)
        if vouched and self.colour is not None:
            agrees = angle is not None and abs(wrap_angle(angle - prior)) < self.disagree
            self.disagreed = 0 if agrees else self.disagreed + 1
            if self.disagreed >= self.config.relearn:
                self.colour, self.last, self.disagreed = None, None, 0
        return angle

    def _read(self, image: np.ndarray, colour: tuple[float, ...], pivot: np.ndarray,
              radius: float, prior: float, vouched: bool,
              directions: tuple[float, float] | None, lost: bool) -> float | None:
        """`update` once the colour is known (``colour``), without the relearning:
        ``vouched`` is DON's reading ``prior``."""
        px, py = float(pivot[0]), float(pivot[1])
        if vouched and self._jumped(prior):
            vouched = False  # search along this layer's track; learn nothing from the frame
        first, end = self._search(round(prior / self.step), vouched, directions, lost)
        if end <= first:
            self.last = None
            return None
        # Rays first .. end - 1 (grid steps, unwrapped): a slice of the maps' rows, which
        # run twice round the circle so that no search wraps.
        map1, map2 = self._ray_maps(px, py, radius)
        sides, turn = len(self.offsets), self.turns
        rows = slice(sides * (first % turn), sides * (first % turn + end - first))
        # The background's match is the rays' lower quartile (a link near the pivot
        # crosses several neighbouring rays).
        best, side = best_ray(cv2.remap(image, map1[rows], map2[rows], cv2.INTER_LINEAR),
                              _rounded(colour), self.table, sides,
                              255 * self.config.min_match, 255 * self.config.min_contrast)
        if best < 0:
            self.last = None
            return None
        angle, offset = (first + best) * self.step, float(self.offsets[side])
        angle, patch, weight = self._fit_line(image, colour, px, py, radius, angle, offset)
        if directions is not None and abs(wrap_angle(angle - directions[0])) > directions[1]:
            self.last = None  # the fit left where the link can point: not the link
            return None
        self.turn = 0.0 if self.last is None else float(wrap_angle(angle - self.last))
        self.last = angle
        if vouched and abs(wrap_angle(angle - prior)) < self.agree:
            self._learn(colour, patch, weight)
        return angle

    def _jumped(self, prior: float) -> bool:
        """Whether DON's reading ``prior`` (rad) lies farther from where this layer's last
        reading and turn put the link now than the search about a vouched reading reaches
        (``near``): DON has jumped away from a link this layer saw in the last frame."""
        return (self.last is not None
                and abs(wrap_angle(prior - self.last - self.turn))
                > self.config.near * self.step)

    def _learn_first(self, image: np.ndarray, pivot: np.ndarray, radius: float,
                     prior: float, vouched: bool) -> None:
        """The first colour from DON's reading ``prior``: learned at once where it is
        ``vouched``; else proposed, and learned (the median of the agreeing ones) once
        ``first_agree`` proposals agree within ``sigma``."""
        px, py = float(pivot[0]), float(pivot[1])
        colour = self._first_colour(image, px, py, radius, prior)
        if colour is None or self._background_colour(image, px, py, radius, colour):
            return
        if not vouched:
            agreeing = [c for c in self.proposals
                        if sum(abs(a - b) for a, b in zip(c[:3], colour[:3], strict=True))
                        < self.config.sigma]
            self.proposals.append(colour)
            if len(agreeing) + 1 < self.config.first_agree:
                return
            colour = (*np.median([c[:3] for c in (*agreeing, colour)], axis=0).tolist(), 0.0)
        self.colour = colour
        self.proposals.clear()

    def _first_colour(self, image: np.ndarray, px: float, py: float, radius: float,
                      angle: float) -> tuple[float, ...] | None:
        """The link's colour from a vouched reading ``angle``: of the points along it
        that differ (summed absolute RGB difference over 2 ``sigma``) from the points at the
        same distances 15 degrees to either side (the background beside the link), the
        median colour of the half that differ most (a thin link's core, not its edges
        blurred into the background); None unless at least half of the points differ (the
        ray may have missed a thin link, and a ray across the background would learn the
        wall)."""
        along = radius * self.fractions[None, :]
        angles = angle + np.radians([0.0, -15.0, 15.0])[:, None]
        xs = (px + np.cos(angles) * along).astype(np.float32)
        ys = (py - np.sin(angles) * along).astype(np.float32)
        link, *beside = cv2.remap(image, xs, ys, cv2.INTER_LINEAR).astype(np.int16)
        difference = np.min([np.abs(link - background).sum(axis=1) for background in beside],
                            axis=0)
        distinct = difference > 2 * self.config.sigma
        if np.count_nonzero(distinct) < len(self.fractions) // 2:
            return None
        core = difference >= np.median(difference[distinct])
        return (*np.median(link[core], axis=0).tolist(), 0.0)

    def _background_colour(self, image: np.ndarray, px: float, py: float, radius: float,
                           colour: tuple[float, ...]) -> bool:
        """Whether ``colour`` matches (within ``sigma``) more than ``max_share`` of the square
        about the pivot (px, py) that the link can reach, 1.6 ``radius`` either side (working
        px): the wall's, not the link's. A vouched ray can run past the link's tip (a
        radius estimate too long, a link half behind a board) and its core be the wall
        beyond: the layer then reads the wall, agreeing with DON wherever the link lies
        against it, and once DON has lost the link (``lost``) it reads the wall wherever
        the joint can point. The share is of the reach, not of the frame: a close view of
        the arm does not make the link's colour look like the wall's."""
        if self.max_share is None:
            return False
        square = image[reach_square(np.array([px, py]), radius)]
        if square.size == 0:
            return False
        matching = cv2.countNonZero(cv2.compare(  # type: ignore[call-overload]
            _match(square, colour, self.table), 94, cv2.CMP_GT))
        return matching > self.max_share * square.shape[0] * square.shape[1]

    def _search(self, prior: int, vouched: bool, directions: tuple[float, float] | None,
                lost: bool) -> tuple[int, int]:
        """The rays to try, first .. end - 1, in grid steps counted from direction 0 and
        unwrapped to lie near ``prior`` (DON's direction, in grid steps): within ``near`` of
        it where DON ``vouched`` for it; else within ``track`` of where the last reading's
        direction and turn rate put the link now; after a frame without a reading, all
        round where DON has ``lost`` the link, else none. Only where the link can point."""
        near, track, turn, step = self.config.near, self.config.track, self.turns, self.step
        if vouched:
            first, end = prior - near, prior + near + 1
        elif self.last is not None:
            ahead = round((self.last + self.turn) / step)
            ahead = prior + (ahead - prior + turn // 2) % turn - turn // 2
            first, end = ahead - track, ahead + track + 1
        elif lost:
            first, end = prior - turn // 2, prior + turn // 2
        else:
            return 0, 0
        if directions is not None and directions[1] < math.pi:
            middle, half_width = directions[0] / step, directions[1] / step
            middle = prior + (middle - prior + turn / 2) % turn - turn / 2
            first = max(first, math.ceil(middle - half_width))
            end = min(end, math.floor(middle + half_width) + 1)
        return first, min(end, first + turn)

    def _ray_maps(self, px: float, py: float, radius: float) -> tuple[np.ndarray, np.ndarray]:
        """cv2.remap maps (fixed point, (2 turns x offsets, fractions) rows and
        columns) of every ray twice round: row 3k + j is direction k steps shifted sideways
        by the j-th offset. Kept while the pivot stays within 0.3 px and the radius within 3%."""
        kept, rays = self._rays_for, self._rays
        if (kept is None or rays is None or abs(kept[0] - px) > 0.3 or abs(kept[1] - py) > 0.3
                or abs(kept[2] - radius) > 0.03 * kept[2]):
            grid = np.arange(2 * self.turns) * self.step
            cos, sin = np.cos(grid)[:, None, None], np.sin(grid)[:, None, None]
            along = radius * self.fractions[None, None, :]
            side = self.offsets[None, :, None]
            # Sideways is the ray's direction turned clockwise on screen: (-sin, -cos).
            xs = (px + cos * along - sin * side).reshape(-1, len(self.fractions))
            ys = (py - sin * along - cos * side).reshape(-1, len(self.fractions))
            rays = self._rays = cv2.convertMaps(xs.astype(np.float32), ys.astype(np.float32),
                                                cv2.CV_16SC2)
            self._rays_for = (px, py, radius)
        return rays

    def _fit_line(self, image: np.ndarray, colour: tuple[float, ...], px: float, py: float,
                  radius: float, angle: float, offset: float
                  ) -> tuple[float, np.ndarray, np.ndarray]:
        """The link's direction from the corridor about the ray at ``angle`` shifted
        sideways by ``offset``: the weighted least-squares line of sideways offset against
        distance (the image moments of the match with ``colour`` in the corridor's
        frame); ``angle`` if the corridor holds too little of the link. Also returns the
        corridor's pixels ((rows, cols, 3) uint8) and their match (0-255)."""
        corridor, s = self.config.corridor_px, self.config.corridor_step
        first, cols = 0.2 * radius, max(2, int(0.8 * radius / s))
        rows = 2 * round(corridor / s) + 1
        side0 = offset - corridor
        cos, sin = math.cos(angle), math.sin(angle)
        # Corridor pixel (u, v) is at distance first + u s along the ray, side0 + v s aside.
        to_image = np.array([[cos * s, -sin * s, px + cos * first - sin * side0],
                             [-sin * s, -cos * s, py - sin * first - cos * side0]])
        patch = cv2.warpAffine(image, to_image, (cols, rows),
                               flags=cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP)
        weight = _match(patch, colour, self.table)
        moments = cv2.moments(weight)
        if moments["m00"] > 3 * 255 and moments["mu20"] > 1e-6:
            # A line turned by a small delta from the ray lies sideways at delta * distance:
            # the slope of offset against distance (rows per column, both ``corridor_step``).
            angle += math.atan(moments["mu11"] / moments["mu20"])
        return angle, patch, weight

    def _learn(self, colour: tuple[float, ...], patch: np.ndarray, weight: np.ndarray
               ) -> None:
        """Move the colour (``colour``, as it stands) toward the mean of the corridor's
        pixels that match it within ``sigma`` (``patch`` (rows, cols, 3) uint8, ``weight``
        their match, 0-255)."""
        count, *mean = close_colour_mean(patch, weight, 94)  # 255 / e
        if count >= 3:
            rate = self.config.learning_rate
            self.colour = (*((1 - rate) * c + rate * m
                             for c, m in zip(colour[:3], mean, strict=True)), 0.0)
