"""DON's appearance layer (ours, not the paper's): the link's direction in the current
frame from its colour, once the motion layers have found it.

Why. Frame differences see a link only where it moves, as slivers at its leading and
trailing edges. Where a distractor crosses near the joint its pixels merge with the
slivers and tilt their axis; where the link turns under a degree a frame there are no
slivers at all and DON holds a stale angle. On development clips those two cases were
most of `exp3-forearm-none`'s error: median 1.7 deg, but the 5% of frames off by more than
10 deg carried two thirds of the squared error. The link itself is in every frame, and it
looks the same from frame to frame: one colour along its length.

How.
- DON vouches for a frame's reading when its motion layers read the link there (not a
  hold, not a prediction) with eta at least VOUCH_TRUST.
- Colour. From the first vouched reading whose direction crosses the link: the median
  colour of the points along it that stand out most from the points 15 degrees to
  either side (at least half of them must stand out). Then a slow running mean of the
  matching pixels along this layer's reading wherever it agrees with a vouched one. A
  colour, not a patch: it does not depend on where the pivot or the radius estimate sits
  along the link. A colour that reads nothing, or something else than DON, in 5 vouched
  frames running was learned from something else (a link first seen in part, blurred
  into its background): it is learned again. (`LinkedDON` counts only the frames with
  no reading: its fit is often off by more than this layer.) A first colour that
  matches over MAX_SHARE of the square the link can reach is the wall's, from a ray run
  on past the link's tip, and is not learned. Settled RMSE on development clips, without
  -> with, seeds 0-79 (chosen; 0.03 and 0.05 also tried) / 80-159 (a check):
  `exp3-forearm-high` 10.82 -> 10.15 deg / 12.26 -> 11.80, `exp3-forearm-low` 6.12 ->
  5.82 / 6.93 -> 6.74, `exp3-forearm-none` 3.52 -> 3.24 / 2.91 -> 2.91,
  `exp1-noisy-fast` 13.26 -> 12.99 / 11.56 -> 10.95, at most one clip worse per
  scenario (the most, `-low` clip 141: 11.2 -> 16.0), `exp2-servo` and `default`
  unchanged (`benchmarks/don_dev_seeds.py --compare`). `LinkedDON` learns any colour:
  with the rule, `chain-3`'s first two joints went 3.48 -> 4.35 and 8.46 -> 9.18 deg
  (`benchmarks/don_links_dev_seeds.py`).
- Colour before a vouched reading. Behind a board, DON's eta seldom reaches VOUCH_TRUST:
  on development clips 0-79 of `exp3-forearm-high` the colour came 15-80 frames after
  the pivot, and a fifth of the squared error was in frames where DON had no reading of
  the link and this layer no colour to look for it with. So a reading with eta from
  FIRST_TRUST proposes a first colour (the same median, the same MAX_SHARE test), and
  one that agrees (summed absolute RGB difference under SIGMA) with an earlier proposal
  is learned: the median of the agreeing ones. One frame's low-trust reading can be of
  an occluder's edge; two that find the same colour seldom are. Settled RMSE on
  development clips, without -> with, seeds 0-79 (chosen among eta 0.4, 0.5, 0.6 and
  two or three proposals) / 80-159 (a check): `exp3-forearm-high` 8.72 -> 8.00 deg /
  10.39 -> 9.43 (95% interval of the change -1.68 to -0.35), `exp3-forearm-low` 5.16
  -> 4.77 / 5.59 -> 5.30 (one clip 5.1 -> 34.0: two proposals of a grey, not skin),
  `exp3-forearm-none` 3.03 -> 2.81 / 2.67 -> 2.57, `exp1-noisy-fast` 11.11 -> 11.22 /
  9.14 -> 8.55, `exp2-servo` and `default` within 0.02. Letting a later vouched
  reading's colour replace a proposed one where they differ kept that clip right but
  lost half the gain on `-high` (-0.43 / -0.72). `LinkedDON` learns from vouched
  readings only, as before.
- Match of a pixel: exp(-(d / SIGMA)^2), d the sum over RGB of absolute differences from
  the colour (under 0.1 counts as none). A ray's match is the mean along it, from 0.3 to
  0.95 radii from the pivot.
- Search. Rays every 2 degrees about DON's pivot, each at three sideways offsets (-2, 0,
  +2 working px) so that a pivot a pixel or two off still lays a ray along the link.
  Where DON vouches, within 12 degrees of its reading: a brighter match elsewhere (a
  static object of the link's colour) cannot pull the reading away. Where it does not
  (the link stalled, hidden, or among clutter that drags DON's trust down), within 24
  degrees of where this layer's own last two readings put the link now; after a frame
  without a reading, nowhere until DON vouches again, unless DON says it has lost the
  link (below): then everywhere. Only where the joint can turn. A best match under 0.25,
  or under 0.15 above the lower quartile's, is no reading.
- A vouched jump. Where DON vouches for a reading more than 12 degrees (the vouched
  search's reach) from where this layer's last reading and turn put the link now, the
  layer searches its own track instead and learns nothing from the frame: DON has
  jumped away from a link this layer still saw. That jump is most often a board's edge
  read as the link while the forearm rests (development clip 68 of
  `exp3-forearm-high`: from 23 to 77 degrees, held for 14 frames); the layer searched
  only near a vouched reading, found nothing there, and the jump stood.
  Settled RMSE on development clips, without -> with, seeds 0-79 (chosen among 6, 10,
  15, 20, 25 and 30 degrees; 10 to 15 gave the same) / 80-159 (a check;
  `benchmarks/don_dev_seeds.py --compare`): `exp3-forearm-low` 4.77 -> 4.37 deg / 5.30
  -> 4.79 (95% interval of the change -1.17 to -0.13; 17 clips better, 1 worse),
  `exp3-forearm-none` 2.81 -> 2.37 / 2.57 -> 2.41 (-0.28 to -0.07), `exp3-forearm-high`
  8.00 -> 7.99 / 9.43 -> 9.39, `exp1-noisy-fast` 11.22 -> 11.18 / 8.55 -> 8.51,
  `default` 0.94 -> 0.93 / 0.96 -> 0.93, `exp2-servo` unchanged. On clip 68 itself the
  track search finds nothing (the board covers nearly half of the forearm by then), so
  the jump still stands there. `LinkedDON`'s layers follow the rule too; its development
  clips, settled RMSE per joint, without -> with (`benchmarks/don_links_dev_seeds.py`):
  `chain-2` 2.14, 2.72 -> 2.21, 2.83 deg, `chain-3` 3.48, 8.46, 20.44 -> 3.06, 7.89,
  20.35, `exp4-hand` 10.35, 22.86, 15.14 -> 10.34, 22.84, 15.20.
- Everywhere once DON has lost the link (DON's ``search_when_lost``, on by default): a
  forearm that comes out from behind the board and rests stays lost to the motion
  layers until it moves (development clip 3 of `exp3-forearm-high`: held 16.6 degrees
  off at frame 88 with the forearm coming into view; within 4.3 with the search). The
  risk is a colour learned from something else: before MAX_SHARE, on clip 18 the colour
  was half the board's brown and the search read the board's edge (settled RMSE 9.5 ->
  27.7 deg). `DON` gives the figures.
- Direction. The best ray is a 2-degree guess. The direction comes from the straight line
  fitted to the matching pixels of a corridor 4 px either side of it (sideways offset
  against distance, weighted by the match): a line's direction does not depend on where
  the pivot is, and this reading is of the current frame, where DON's from a difference
  image is half a frame old.

What it cannot fix is a wrong pivot (the search's rays start there) or a link hidden for
longer than its track lasts.
"""

from __future__ import annotations

import math
from collections import deque

import cv2
import numpy as np

from imimic_gym.estimators.compiled import best_ray, close_colour_mean, colour_match
from imimic_gym.estimators.geometry import reach_square
from imimic_gym.kinematics import wrap_angle

__all__ = ["LinkAppearance"]

STEP = math.radians(2.0)  # the search's spacing of ray directions
TURN = 180  # grid steps in a turn
VOUCH_TRUST = 0.8  # DON's eta from which its reading of the link vouches for it
FIRST_TRUST = 0.5  # DON's eta from which its reading proposes a first colour
FIRST_AGREE = 2  # proposals agreeing within SIGMA that make the first colour
PROPOSALS = 10  # the proposals remembered, newest last
NEAR = 6  # where DON vouches, how far (grid steps: 12 deg) from its reading to look
TRACK = 12  # where not, how far (grid steps) from where this layer's track puts the link
AGREE = math.radians(3.0)  # a reading this close to a vouched one teaches the colour
RELEARN = 5  # vouched frames running that this layer reads nothing or more than
DISAGREE = math.radians(6.0)  # this far off make the colour learned anew
OFFSETS = np.array([-2.0, 0.0, 2.0])  # sideways ray offsets, working px
FRACTIONS = np.linspace(0.3, 0.95, 14)  # where along the link a ray is sampled, radii
SIGMA = 35.0  # summed absolute RGB difference (grey levels) at which a match is exp(-1)
MIN_MATCH, MIN_CONTRAST = 0.25, 0.15
# A first colour matching (within SIGMA) more than this share of the square the link can
# reach (1.6 radii about the pivot) is the background's: a link is a bar from the pivot,
# its width a quarter of its length at most (a forearm seen close), about 2.5% of it.
MAX_SHARE = 0.1
LEARNING_RATE = 0.1
CORRIDOR_PX, CORRIDOR_STEP = 4.0, 0.5  # the line fit's half-width and sample spacing, px
# Match (0-255) per summed absolute difference (0-255, saturated); under 0.1 is none.
_MATCH = 255 * np.exp(-(np.arange(256) / SIGMA) ** 2)
_MATCH = np.where(_MATCH < 25.5, 0, np.round(_MATCH)).astype(np.uint8)


def _match(colours: np.ndarray, colour: tuple[float, ...]) -> np.ndarray:
    """Per-pixel match (0-255 uint8, (h, w)) of (h, w, 3) uint8 colours with ``colour``."""
    return colour_match(colours, _rounded(colour), _MATCH)


def _rounded(colour: tuple[float, ...]) -> tuple[int, int, int]:
    """``colour``'s RGB as the integers a match compares with: rounded half to even
    (Python's round, as OpenCV rounds a scalar against uint8 pixels)."""
    r, g, b = (round(c) for c in colour[:3])
    return r, g, b


class LinkAppearance:
    """Reads one link's direction from its colour, about a pivot found elsewhere.

    Directions are radians, counter-clockwise with the image's y axis up; coordinates
    are working-resolution pixels (x right, y down), as in `geometry.py`.

    Args:
        disagree: how far (rad) this layer's reading may lie from a vouched one before
            the frame counts against the colour (RELEARN such frames running and it is
            learned anew); ``math.inf``: only vouched frames without a reading count,
            for a caller whose vouched readings are often off by more (`LinkedDON`).
        max_share: a first colour matching more than this share of the square the link
            can reach is not learned (`_background_colour`); None: any colour is.
        first_trust: from this eta (below VOUCH_TRUST) a reading proposes a first colour,
            learned once FIRST_AGREE proposals agree; None: only vouched readings teach it.
    """

    def __init__(self, disagree: float = DISAGREE, max_share: float | None = MAX_SHARE,
                 first_trust: float | None = FIRST_TRUST) -> None:
        self.disagree, self.max_share, self.first_trust = disagree, max_share, first_trust
        self.reset()

    def reset(self) -> None:
        self.colour: tuple[float, ...] | None = None  # RGB (and a 0 for OpenCV's scalar)
        self.last: float | None = None  # the last frame's reading, rad (None: no reading)
        self.turn = 0.0  # how far the link turned between the last two readings, rad
        self.disagreed = 0  # vouched frames running that this layer read otherwise or not
        # First colours proposed by readings DON trusts less than it vouches (RGB, 0).
        self.proposals: deque[tuple[float, ...]] = deque(maxlen=PROPOSALS)
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

        A colour that fails RELEARN vouched frames running (no reading, or one more than
        ``disagree`` from DON's) was learned from something else: it is dropped and learned
        again from the next vouched frame.
        """
        vouched = read and trust >= VOUCH_TRUST
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
            if self.disagreed >= RELEARN:
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
        first, end = self._search(round(prior / STEP), vouched, directions, lost)
        if end <= first:
            self.last = None
            return None
        # Rays first .. end - 1 (grid steps, unwrapped): a slice of the maps' rows, which
        # run twice round the circle so that no search wraps.
        map1, map2 = self._ray_maps(px, py, radius)
        rows = slice(len(OFFSETS) * (first % TURN), len(OFFSETS) * (first % TURN + end - first))
        # The background's match is the rays' lower quartile (a link near the pivot
        # crosses several neighbouring rays).
        best, side = best_ray(cv2.remap(image, map1[rows], map2[rows], cv2.INTER_LINEAR),
                              _rounded(colour), _MATCH, len(OFFSETS), 255 * MIN_MATCH,
                              255 * MIN_CONTRAST)
        if best < 0:
            self.last = None
            return None
        angle, offset = (first + best) * STEP, float(OFFSETS[side])
        angle, patch, weight = self._fit_line(image, colour, px, py, radius, angle, offset)
        if directions is not None and abs(wrap_angle(angle - directions[0])) > directions[1]:
            self.last = None  # the fit left where the link can point: not the link
            return None
        self.turn = 0.0 if self.last is None else float(wrap_angle(angle - self.last))
        self.last = angle
        if vouched and abs(wrap_angle(angle - prior)) < AGREE:
            self._learn(colour, patch, weight)
        return angle

    def _jumped(self, prior: float) -> bool:
        """Whether DON's reading ``prior`` (rad) lies farther from where this layer's last
        reading and turn put the link now than the search about a vouched reading reaches
        (NEAR): DON has jumped away from a link this layer saw in the last frame."""
        return (self.last is not None
                and abs(wrap_angle(prior - self.last - self.turn)) > NEAR * STEP)

    def _learn_first(self, image: np.ndarray, pivot: np.ndarray, radius: float,
                     prior: float, vouched: bool) -> None:
        """The first colour from DON's reading ``prior``: learned at once where it is
        ``vouched``; else proposed, and learned (the median of the agreeing ones) once
        FIRST_AGREE proposals agree within SIGMA."""
        px, py = float(pivot[0]), float(pivot[1])
        colour = self._first_colour(image, px, py, radius, prior)
        if colour is None or self._background_colour(image, px, py, radius, colour):
            return
        if not vouched:
            agreeing = [c for c in self.proposals
                        if sum(abs(a - b) for a, b in zip(c[:3], colour[:3], strict=True)) < SIGMA]
            self.proposals.append(colour)
            if len(agreeing) + 1 < FIRST_AGREE:
                return
            colour = (*np.median([c[:3] for c in (*agreeing, colour)], axis=0).tolist(), 0.0)
        self.colour = colour
        self.proposals.clear()

    @staticmethod
    def _first_colour(image: np.ndarray, px: float, py: float, radius: float,
                      angle: float) -> tuple[float, ...] | None:
        """The link's colour from a vouched reading ``angle``: of the points along it
        that differ (summed absolute RGB difference over 2 SIGMA) from the points at the
        same distances 15 degrees to either side (the background beside the link), the
        median colour of the half that differ most (a thin link's core, not its edges
        blurred into the background); None unless at least half of the points differ (the
        ray may have missed a thin link, and a ray across the background would learn the
        wall)."""
        along = radius * FRACTIONS[None, :]
        angles = angle + np.radians([0.0, -15.0, 15.0])[:, None]
        xs = (px + np.cos(angles) * along).astype(np.float32)
        ys = (py - np.sin(angles) * along).astype(np.float32)
        link, *beside = cv2.remap(image, xs, ys, cv2.INTER_LINEAR).astype(np.int16)
        difference = np.min([np.abs(link - background).sum(axis=1) for background in beside],
                            axis=0)
        distinct = difference > 2 * SIGMA
        if np.count_nonzero(distinct) < len(FRACTIONS) // 2:
            return None
        core = difference >= np.median(difference[distinct])
        return (*np.median(link[core], axis=0).tolist(), 0.0)

    def _background_colour(self, image: np.ndarray, px: float, py: float, radius: float,
                           colour: tuple[float, ...]) -> bool:
        """Whether ``colour`` matches (within SIGMA) more than ``max_share`` of the square
        about the pivot (px, py) that the link can reach, 1.6 ``radius`` either side (working
        px): the wall's, not the link's. A vouched ray can run past the link's tip (a
        radius estimate too long, a link half behind a board) and its core be the wall
        beyond: the layer then reads the wall, agreeing with DON wherever the link lies
        against it, and once DON has lost the link (``lost``) it reads the wall wherever
        the joint can point. On development clips of `exp3-forearm-high`, the first colours
        learned from the link matched 0.3-1.7% of this square, those learned from
        something else up to 34%. The share is of the reach, not of the frame: a close
        view of the arm does not make the link's colour look like the wall's."""
        if self.max_share is None:
            return False
        square = image[reach_square(np.array([px, py]), radius)]
        if square.size == 0:
            return False
        matching = cv2.countNonZero(cv2.compare(  # type: ignore[call-overload]
            _match(square, colour), 94, cv2.CMP_GT))
        return matching > self.max_share * square.shape[0] * square.shape[1]

    def _search(self, prior: int, vouched: bool, directions: tuple[float, float] | None,
                lost: bool) -> tuple[int, int]:
        """The rays to try, first .. end - 1, in grid steps counted from direction 0 and
        unwrapped to lie near ``prior`` (DON's direction, in grid steps): within NEAR of
        it where DON ``vouched`` for it; else within TRACK of where the last reading's
        direction and turn rate put the link now; after a frame without a reading, all
        round where DON has ``lost`` the link, else none. Only where the link can point."""
        if vouched:
            first, end = prior - NEAR, prior + NEAR + 1
        elif self.last is not None:
            ahead = round((self.last + self.turn) / STEP)
            ahead = prior + (ahead - prior + TURN // 2) % TURN - TURN // 2
            first, end = ahead - TRACK, ahead + TRACK + 1
        elif lost:
            first, end = prior - TURN // 2, prior + TURN // 2
        else:
            return 0, 0
        if directions is not None and directions[1] < math.pi:
            middle, half_width = directions[0] / STEP, directions[1] / STEP
            middle = prior + (middle - prior + TURN / 2) % TURN - TURN / 2
            first = max(first, math.ceil(middle - half_width))
            end = min(end, math.floor(middle + half_width) + 1)
        return first, min(end, first + TURN)

    def _ray_maps(self, px: float, py: float, radius: float) -> tuple[np.ndarray, np.ndarray]:
        """cv2.remap maps (fixed point, (2 TURN len(OFFSETS), len(FRACTIONS)) rows and
        columns) of every ray twice round: row 3k + j is direction k STEP shifted sideways
        by OFFSETS[j]. Kept while the pivot stays within 0.3 px and the radius within 3%."""
        kept, rays = self._rays_for, self._rays
        if (kept is None or rays is None or abs(kept[0] - px) > 0.3 or abs(kept[1] - py) > 0.3
                or abs(kept[2] - radius) > 0.03 * kept[2]):
            grid = np.arange(2 * TURN) * STEP
            cos, sin = np.cos(grid)[:, None, None], np.sin(grid)[:, None, None]
            along, side = radius * FRACTIONS[None, None, :], OFFSETS[None, :, None]
            # Sideways is the ray's direction turned clockwise on screen: (-sin, -cos).
            xs = (px + cos * along - sin * side).reshape(-1, len(FRACTIONS))
            ys = (py - sin * along - cos * side).reshape(-1, len(FRACTIONS))
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
        first, cols = 0.2 * radius, max(2, int(0.8 * radius / CORRIDOR_STEP))
        rows = 2 * round(CORRIDOR_PX / CORRIDOR_STEP) + 1
        side0 = offset - CORRIDOR_PX
        cos, sin, s = math.cos(angle), math.sin(angle), CORRIDOR_STEP
        # Corridor pixel (u, v) is at distance first + u s along the ray, side0 + v s aside.
        to_image = np.array([[cos * s, -sin * s, px + cos * first - sin * side0],
                             [-sin * s, -cos * s, py - sin * first - cos * side0]])
        patch = cv2.warpAffine(image, to_image, (cols, rows),
                               flags=cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP)
        weight = _match(patch, colour)
        moments = cv2.moments(weight)
        if moments["m00"] > 3 * 255 and moments["mu20"] > 1e-6:
            # A line turned by a small delta from the ray lies sideways at delta * distance:
            # the slope of offset against distance (rows per column, both CORRIDOR_STEP).
            angle += math.atan(moments["mu11"] / moments["mu20"])
        return angle, patch, weight

    def _learn(self, colour: tuple[float, ...], patch: np.ndarray, weight: np.ndarray
               ) -> None:
        """Move the colour (``colour``, as it stands) toward the mean of the corridor's
        pixels that match it within SIGMA (``patch`` (rows, cols, 3) uint8, ``weight``
        their match, 0-255)."""
        count, *mean = close_colour_mean(patch, weight, 94)  # 255 / e
        if count >= 3:
            self.colour = (*((1 - LEARNING_RATE) * c + LEARNING_RATE * m
                             for c, m in zip(colour[:3], mean, strict=True)), 0.0)
