"""DON, the paper's unsupervised vision-to-motion network (§3), one layer per unit.

Frames in, joint angle, angular velocity, acceleration and torque out, from frame
differences alone: no labels, no background model.

Decisions where the paper is vague or inconsistent (each is also noted where it acts):

- Working resolution. Every layer runs on the frame area-averaged down to
  ``working_height`` rows (120: half of the paper's 240x320), with any Gaussian scaled by
  the same factor, in colour (`frames.py`). Angles are scale-free; pixel outputs are
  scaled back.
- Smoothing and threshold: no Gaussian (``gaussian=0``), only the area average down to
  the working resolution (a 2x2 box at 240 rows), and 8 grey levels; not the paper's
  15x15 and 12. A forearm is 5-6 px wide at 240x320 with the person 2.2 m away. The
  paper's kernel spreads it over three times that, and a forearm turning a degree or two
  per frame then changes no pixel by 12 levels, so DON held a stale angle through every
  slow stretch: with the elbow given, settled RMSE 6.6 -> 5.5 deg on
  `exp3-forearm-none`, 11.5 -> 8.7 on `exp3-forearm-low`, 17.9 -> 15.9 on
  `exp3-forearm-high` with a 7x7 kernel and 8 levels (`benchmarks/don_dev_seeds.py
  --pivot-given`, with ``--param gaussian=15 --param threshold=12`` and with ``--param
  gaussian=7``). The 7x7 (3x3, sigma 0.7, at 120 rows) still did so, less, and no kernel
  at all did better on development clips, settled RMSE 7x7 -> none, seeds 0-79 (chosen)
  / 80-159 (a check; `benchmarks/don_dev_seeds.py --param gaussian=7 --json F`, then
  ``--compare F``): `exp3-forearm-none` 2.08 -> 1.47 / 2.41 -> 1.72 deg, `exp3-forearm-low` 4.37 ->
  3.16 / 4.78 -> 3.08 (95% interval of the change on 80-159 -2.7 to -0.9),
  `exp3-forearm-high` 7.95 -> 7.34 / 9.01 -> 6.86 (-3.7 to -0.7), `default` 0.93 ->
  0.73 / 0.93 -> 0.72, `exp1-noisy-fast` 11.17 -> 9.17 / 8.46 -> 9.05 (-1.1 to +2.3),
  and worse only on `exp2-servo`, 0.43 -> 0.76 / 0.46 -> 0.74 (a white bar's edges
  turning slowly leave dotted slivers). On seeds 160-319, which no rule had been chosen
  on: `exp3-forearm-low` 5.95 -> 3.39 (-3.4 to -1.8), `exp3-forearm-high` 9.96 -> 7.28
  (-3.6 to -1.8). With camera noise added (Gaussian, sigma 2 and 4 grey levels per
  pixel and frame, seeds 0-39) it still did better: `exp3-forearm-low` 4.91 -> 2.44 and
  4.62 -> 2.91, `exp3-forearm-none` 2.41 -> 1.55 and 2.30 -> 1.60; the area average
  halves that noise before the threshold sees it. A [1, 2, 1] kernel (more smoothing)
  did worse (seeds 0-79, `exp3-forearm-low` 4.37 -> 6.12); without a kernel, thresholds
  of 6, 10 and 12 were within the clips' noise of 8, which stayed. It also takes 40% off
  layer 1's time (`benchmarks/don_stages.py` at 240x320: 69 -> 40 us a frame). On a
  hard-edged white bar on black (the tests' bar) the link's visible length then scatters
  by about 3%, so eta reads 0.94-0.99 in the clear rather than 0.97-0.99. Depth video
  keeps the 7x7 (`DEPTH_GAUSSIAN` says why).
- Difference indices. The paper's Eq. (f1) runs p = 0..N-1 and so needs f_{t+1}; we use
  delta1_p = |f_{t-p+1} - f_{t-p}|, p = 1..N, so delta1_1 is the newest difference.
- Incremental union. |f_t - f_{t-p}| > tau for some p exactly when f_t > min_p f_{t-p} +
  tau or f_t < max_p f_{t-p} - tau. A sliding minimum and maximum over the N previous
  frames (van Herk / Gil-Werman, amortised O(1) images per frame) give the union of the
  N delta2 in two comparisons instead of N differences.
- Object identification per frame. l_1 = (union delta2) & delta1_1 is computed for the
  new frame; the locations and sizes of l_2..l_N are the ones computed when those frames
  were new. Re-intersecting older delta1 with today's union only drops noise pixels.
- A slow link. Turning under a degree a frame, a forearm changes no pixel by the
  threshold between two frames, so l_1 is empty along it and the paper's network holds
  a stale angle. Where l_1 shows no link (and the link is not hidden), DON reads it
  from delta2_{N/2} & delta2_N instead: the pixels the current frame differs in from
  both half a window and a whole window back are where the link is now and was at
  neither time (`DON._slow_reading`).
- Before the pivot is agreed: the link's direction about the last solve's pivot, while
  it waits for the next solve to agree; before any solve, the longest moving region's
  axis, unless it is short (moving clutter) or lies where an occluder's sliding edge
  should be or has stopped; where no region will do, the longest one left once the
  sliding edges are erased from l_1 (`LinkTracker.before_pivot`). These guesses feed
  the path estimator too (a guess that jumps by `GUESS_JUMP` restarts it), so omega does
  not wait for the pivot, and the trust factor, with the guessed region's size as M_p.
  Before anything has moved, DON reports the middle of the joint range with eta 0: a
  placeholder, not a reading.
- Object regression, pivot and radius (`geometry.py`). The paper adds a line per link
  for n links; we fit one per moving region of l_1 (its principal axis) for one link
  too. The link turns about a pivot that never moves, so its regions lie along rays
  through it: the pivot is the mode of the pairwise intersections of recent lines (the
  paper never says how it finds the pivot), counting only crossings near which both
  regions start (`geometry.PivotEstimator`), and leaving out edges that slide sideways
  from one frame to the next (an occluder's sides: a turning link's slivers turn). The
  radius r (skeleton length) is the reach of the regions along the link.
- Re-seeking the pivot (``reseek``, on). Each moving edge is followed from frame to frame;
  one that keeps its direction for 6 frames (an occluder's side creeping too slowly to
  count as sliding) leaves the pivot estimate and is not read as the link, and a second
  pivot estimate, fed after agreement too, replaces the pivot when the recent lines fan
  out from it over more directions (`geometry.LinkTracker`). Settled RMSE on development
  clips, off -> on: seeds 0-79 (chosen there) `exp3-forearm-none` 3.26 -> 3.59 deg (one
  clip 2.0 -> 27.1), `exp3-forearm-low` 11.85 -> 9.75, `exp3-forearm-high` 19.40 ->
  16.25, `exp1-noisy-fast` 15.46 -> 13.44; seeds 80-159 (a check) 2.94 -> 2.90, 12.22 ->
  9.99 (95% interval of the change -3.9 to -0.6), 19.83 -> 16.76 (-5.0 to -1.3), 12.45
  -> 11.92 (-2.7 to +1.3); `exp2-servo` and `default` within 0.01
  (`benchmarks/don_dev_seeds.py --seeds 80 160 --param reseek=False --json F`, then
  ``--compare F``). Final pivots over 15 input px from the elbow, of 80 clips, 0-79 /
  80-159: `exp3-forearm-high` 14 -> 2 / 12 -> 5, `exp3-forearm-low` 5 -> 4 / 6 -> 3,
  `exp1-noisy-fast` 9 -> 3 / 5 -> 3. It costs about 5-10% of DON's time.
- Seeing past an occluder's edge. Where the link touches an occluder's sliding edge
  their moving pixels merge into one region along no ray from the pivot, and DON lost
  (and held) a link in full view. Where no region is the link, `LinkTracker.measure`
  erases the edges that slid lately from l_1, where their last shift puts them now, and
  looks again (`geometry.EDGE_MEMORY`). Settled RMSE on development clips, before ->
  after, seeds 0-79 / 80-159 (95% interval of the change on 80-159): `exp3-forearm-high`
  16.25 -> 14.29 / 16.76 -> 14.58 (-3.4 to -1.1), `exp3-forearm-low` 9.75 -> 9.20 /
  9.99 -> 9.20 (-1.7 to +0.0), `exp1-noisy-fast` 13.44 -> 13.44 / 11.92 -> 11.75,
  `exp3-forearm-none` 3.59 -> 3.59 / 2.90 -> 2.87, `exp2-servo` and `default` unchanged.
  What is left of a board can also be read as the link: 13 of 80 clips of
  `exp3-forearm-high` got worse (seed 63 21.6 -> 38.7). Looking again only within 5
  frames of the last reading, or keeping only readings within 20 degrees of the last,
  lost most of the gain (seeds 0-39: 17.20 -> 15.17 as built, 16.72 and 15.83 so).
- Location. s = the link's direction: the weighted mean axis of the regions that lie on
  a ray from the pivot. delta1_1 spans frames t-1 and t, so s lags by half a frame: the
  angle reported for frame t is s + v/2. A jump of more than `MAX_TURN` in one frame is
  the link found again after a lost or wrong reading, not motion: the path estimator
  starts afresh there rather than report thousands of degrees a second.
- Trust and prediction. eta per Eq. (TF), with M_p the link's visible length rather than
  the raw moving area (`DON.trust_factor` says why); a link that was turning and vanishes
  counts as size 0. The prediction layer (on when ``trust_threshold`` > 0) takes over
  where the link is hidden, or seen only in part (M_1 under PARTIAL of the window's
  largest) with eta below the threshold: it rolls the last trusted velocity on for at
  most N frames, then holds. Through frames without a reading it starts only from a
  reading with eta of at least PREDICT_FROM_TRUST; after a less trusted one it holds.
  Not with Eq. (VAPr) as printed, v <- v + a, a <- a + a': V
  and A differenced from frame to frame are noisy, and that cubic extrapolation ran away
  within a few frames of an occlusion, even capped at the largest v and a seen (tried
  on development clips; it was worse than no prediction at all). Eq. (VAPr)'s recursion
  is kept with the acceleration set to brake the arm, a = -(1 - COAST_DECAY) v, so v
  shrinks by COAST_DECAY a frame: on the occluded frames of development clips, 17.8
  deg with the layer on (threshold 0.3) against 18.7 off on `exp3-forearm-low`, 27.9
  against 28.9 on `exp3-forearm-high` (`benchmarks/don_dev_seeds.py --param
  trust_threshold=0.3`). A frame with no motion at all keeps the last estimate and eta
  = 1 ("nothing to distrust"), once there is an estimate to keep. Nothing here can
  produce NaN.
- Appearance layer (ours, on by default; ``appearance=False`` gives the paper's layers
  alone). Once the motion layers have found the pivot and the link, `appearance.py` reads
  the link's direction in the current frame from its colour; where it sees the link, its
  reading replaces this frame's location (in the path estimator too, and with no
  half-frame lead: it is of the current frame). The trust factor stays Eq. (TF) of the
  motion layers. Settled RMSE on development clips, seeds 0-39, paper's layers alone ->
  with the layer (`benchmarks/don_dev_seeds.py --seeds 0 40`, with and without ``--param
  appearance=False``): `exp3-forearm-none` 5.67 -> 2.64 deg, `exp3-forearm-low` 13.53 ->
  10.96, `exp3-forearm-high` 21.94 -> 19.76, `exp2-servo` 0.52 -> 0.45, `default` 2.78
  -> 0.92, `exp1-noisy-fast` 22.59 -> 15.72. It costs about 0.1 ms a frame (a fifth of
  DON's time at 240x320; `benchmarks/don_stages.py`).
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Iterable
from typing import NamedTuple

import cv2
import mujoco
import numpy as np

from imimic_gym.estimators.appearance import LinkAppearance
from imimic_gym.estimators.compiled import keep_window_changes, running_extrema
from imimic_gym.estimators.frames import FrameShapeError, WorkingFrames
from imimic_gym.estimators.geometry import LinkTracker, component_lines, within_range
from imimic_gym.estimators.motion import PathEstimator, TorqueModel
from imimic_gym.estimators.types import Estimate
from imimic_gym.kinematics import wrap_angle

__all__ = ["DEPTH_GAUSSIAN", "DON", "FrameShapeError", "MotionMask", "SlidingExtrema",
           "gaussian_for"]

# How far (working px) a moving region may reach back past the pivot and still be the
# link: a sliver of l_1 starts at the pivot, give or take the link's rounded end.
REACH_BACK_PX = 2.0
# The fastest turn (rad/frame) read as motion: exp1-noisy-fast's arm peaks at 31 degrees a
# frame at 30 fps.
MAX_TURN = math.radians(45.0)
# Before the pivot is agreed a guess is a region's axis, and the region it comes from can
# change between frames: a guess this far (rad) from the last one starts the path afresh.
# On development clips, 10 degrees kept the servo's gain from omega before the pivot
# (velocity control 1.66 -> 1.13 deg) without the person scenarios' switches (none and
# low within 0.1 deg; with no limit they lost 0.5).
GUESS_JUMP = math.radians(10.0)
# The prediction layer: the velocity kept from one predicted frame to the next, and how
# small a share of the window's largest visible length makes a reading partial.
COAST_DECAY, PARTIAL = 0.8, 0.6
# The prediction layer rolls the link on through frames without a reading only from a
# velocity DON trusted: where eta was at least this at the last frame the motion layers
# read the link (the appearance layer's VOUCH_TRUST). A link read in part just before it
# vanished (development clip 66 of `exp3-forearm-low`: eta 0.38, the reading 35 degrees
# off) gave a velocity that rolled it the wrong way, 47 -> 65 degrees off in five frames.
# Occluded-frame RMSE on development clips with the layer on (threshold 0.3), without ->
# with this rule, seeds 0-79 (chosen) / 80-159 (a check): `exp3-forearm-low` 8.45 -> 8.36
# / 7.46 -> 7.46 deg, `exp3-forearm-high` 13.52 -> 13.67 / 14.29 -> 14.20; with the layer
# off 8.38 / 7.57 and 13.76 / 14.25. So with the rule the layer lowers the occluded error
# in both scenarios on both halves, where without it it raised it on `-low` 0-79 and on
# `-high` 80-159. 0.5 (tried on 0-79) left `-low` at 8.38, no lower than off. Held-out,
# measured once after: `-low` 15.72 -> 15.55 (off 15.57), `-high` 22.04 -> 22.12 (off
# 21.78); on 30 fresh clips `-low` 10.16 -> 10.53 (off 10.53), `-high` 17.77 -> 17.58 (off
# 17.37). The layer acts less: most clips read as with it off, large wins and losses gone.
PREDICT_FROM_TRUST = 0.8
# The Gaussian (kernel size at 240 rows) for DON on depth video, where colour takes none
# (module docstring). Depth frames are the depth buffer quantised to grey levels, without
# the anti-aliasing of the colour render, and their hard steps scatter the link's moving
# pixels as the tests' hard-edged bar does. Settled RMSE on development clips' depth
# video, no Gaussian -> 7x7, seeds 0-79 / 80-159 (`benchmarks/don_dev_seeds.py --modality
# depth`): `exp3-forearm-none` 4.04 -> 1.85 / 3.24 -> 1.67 deg, `exp3-forearm-low` 6.71 ->
# 5.73 / 5.74 -> 4.76, `default` 1.86 -> 0.39 / 1.76 -> 0.38, `exp2-servo` 0.75 -> 0.36 /
# 0.72 -> 0.42, `exp3-forearm-high` 12.58 -> 11.24 / 11.70 -> 12.23, and only
# `exp1-noisy-fast` worse, 10.72 -> 15.47 / 10.51 -> 15.27. So depth keeps the 7x7 DON
# used on colour before (`ImitateVideo-v0(modality="depth")` behind `DONObservation`, and
# `imimic eval --modality depth`).
DEPTH_GAUSSIAN = 7
# A link last seen turning this fast (deg/frame) that leaves no moving pixel at all has
# vanished (behind something), not stopped: a smooth stop slows through the speeds DON
# still sees.
VANISH_DEG = 1.5
# Over this share of the working frame's pixels moving at once, a frame shows no link's
# motion but a cut, a flash or noise: no reading, trust 0, the link held (the rendered
# scenarios peak at 6%, colour and depth).
SCENE_CHANGE = 0.5


def gaussian_for(modality: str) -> int:
    """DON's ``gaussian`` for video of ``modality`` ("rgb" or "depth", as
    `ImitateVideo-v0` shows it): none for colour, `DEPTH_GAUSSIAN` for depth."""
    return DEPTH_GAUSSIAN if modality == "depth" else 0


class Reading(NamedTuple):
    """One frame's reading before it becomes an `Estimate`: the link's image direction
    (rad), omega (rad/s), alpha (rad/s^2), eta, and whether the prediction layer gave it."""

    angle: float
    omega: float
    alpha: float
    trust: float
    predicted: bool


def _any_channel_above(difference: np.ndarray, tau: int) -> np.ndarray:
    """(H, W) uint8, nonzero where some colour channel of ``difference`` exceeds ``tau``.
    Thresholding each channel, then converting to grey (positive exactly where any channel
    passed), is two SIMD passes; numpy's max over the channel axis is 30x slower."""
    _, passed = cv2.threshold(difference, tau, 255, cv2.THRESH_BINARY)
    return cv2.cvtColor(passed, cv2.COLOR_RGB2GRAY)


class SlidingExtrema:
    """Per-pixel minimum and maximum of the last N images, amortised O(1) images per push.

    Van Herk / Gil-Werman over time: the window is the tail of the previous block of N
    (whose suffix extrema were computed once, when it filled) plus the current block
    (whose running extrema grow by one image per push).
    """

    def __init__(self, n: int) -> None:
        self.n = n
        self.block: list[np.ndarray] = []
        self.run_min: np.ndarray | None = None
        self.run_max: np.ndarray | None = None
        self.suffix_min: list[np.ndarray] = []
        self.suffix_max: list[np.ndarray] = []

    def parts(self) -> tuple[tuple[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]:
        """Two (min, max) pairs of whole images whose elementwise min (of the mins) and
        max (of the maxes) are the extrema over the last N pushed images (fewer at the
        start): the previous block's suffix and the current block's run (one pair twice
        where only one exists). Nothing is combined until a caller needs it, and then
        only where it does (`compiled.keep_window_changes`)."""
        k = len(self.block)
        if k == 0:
            whole = (self.suffix_min[0], self.suffix_max[0])
            return whole, whole
        assert self.run_min is not None and self.run_max is not None  # set by every push
        run = (self.run_min, self.run_max)
        if not self.suffix_min:
            return run, run
        return (self.suffix_min[k], self.suffix_max[k]), run

    def extrema(self, box: tuple[slice, slice] = (slice(None), slice(None))
                ) -> tuple[np.ndarray, np.ndarray]:
        """(min, max) over the last N pushed images (fewer at the start), within ``box``
        (row and column slices; the whole image by default)."""
        (low_a, high_a), (low_b, high_b) = self.parts()
        return cv2.min(low_a[box], low_b[box]), cv2.max(high_a[box], high_b[box])

    def push(self, image: np.ndarray) -> None:
        if self.run_min is None or self.run_max is None:  # a new block
            self.run_min, self.run_max = image, image
        else:
            self.run_min, self.run_max = running_extrema(self.run_min, self.run_max, image)
        self.block.append(image)
        if len(self.block) == self.n:
            lows, highs = [self.block[-1]], [self.block[-1]]
            for img in reversed(self.block[:-1]):
                low, high = running_extrema(lows[-1], highs[-1], img)
                lows.append(low)
                highs.append(high)
            self.suffix_min, self.suffix_max = lows[::-1], highs[::-1]
            self.block, self.run_min, self.run_max = [], None, None


class MotionMask:
    """DON layers 1-3: each frame in, l_1 = (union_p delta2_p) & delta1_1 (paper Eq. OL)
    out, the pixels that surely moved, (h, w) uint8 at the working resolution, nonzero
    where the pixel moves. Shared by the one-link `DON` and `LinkedDON`.

    Args:
        window: N, the frames in the input layer (paper: 10).
        gaussian: the paper's Gaussian kernel size at 240 rows.
        threshold: binarisation threshold of a difference, grey levels, any channel.
        working_height: rows of the working resolution.
        name: the estimator's name, for error messages.
    """

    def __init__(self, window: int = 10, gaussian: int = 15, threshold: int = 12,
                 working_height: int = 120, name: str = "DON") -> None:
        if window < 2:
            raise ValueError(f"window must be at least 2 frames, got {window}")
        self.frames = WorkingFrames(working_height, gaussian, name=name)
        self.window, self.threshold = window, threshold
        self.reset()

    def reset(self) -> None:
        self.frames.reset()
        self.previous: np.ndarray | None = None
        self.extrema = SlidingExtrema(self.window)
        self.history: deque[np.ndarray] = deque(maxlen=self.window + 1)
        # The newest l_1's pixel count and bounding box (left, top, width, height).
        self.area, self.box = 0, (0, 0, 0, 0)

    @property
    def scale(self) -> float:
        """Input pixels per working pixel (known after the first frame)."""
        return self.frames.scale

    def __call__(self, frame: np.ndarray) -> np.ndarray | None:
        """l_1 for ``frame`` (H, W, 3) uint8 RGB; None for the first frame."""
        image = self.frames(frame)  # layer 1: input window, downscaled and smoothed
        mask = None if self.previous is None else self._moving_pixels(image, self.previous)
        self.previous = image
        self.extrema.push(image)
        self.history.append(image)
        return mask

    @property
    def scene_changed(self) -> bool:
        """The newest frame changed over more than `SCENE_CHANGE` of the working frame:
        no link's motion, a cut, a flash or noise."""
        width, height = self.frames.size
        return self.area > SCENE_CHANGE * width * height

    def difference_to(self, frames_back: int,
                      box: tuple[slice, slice] = (slice(None), slice(None))) -> np.ndarray:
        """delta2 of the newest frame to the one ``frames_back`` before it, binarised as
        layer 2 does, within ``box`` (row and column slices; the whole frame by default):
        (h, w) uint8, nonzero where some channel differs by more than the threshold."""
        mask = np.zeros(self.history[-1].shape[:2], dtype=np.uint8)
        mask[box] = _any_channel_above(
            cv2.absdiff(self.history[-1][box], self.history[-1 - frames_back][box]),
            self.threshold)
        return mask

    def _moving_pixels(self, image: np.ndarray, previous: np.ndarray) -> np.ndarray:
        tau = self.threshold
        # DON layer 2: frame difference, paper Eqs. (f1), (f2), binarised.
        # A pixel differs when any colour channel differs by more than tau; f_t differs
        # from some f_{t-p} exactly when it rises above the window's minimum or falls below
        # its maximum, so one saturating difference each, merged, covers every delta2_p.
        delta1 = _any_channel_above(cv2.absdiff(image, previous), tau)
        # The union matters only where delta1 is set: within its bounding box (2-40% of
        # the frame in the rendered scenarios; nothing at all on a still frame).
        left, top, width, height = cv2.boundingRect(delta1)
        if width == 0:
            self.area, self.box = 0, (0, 0, 0, 0)
            return delta1
        # DON layer 3: object identification, paper Eq. (OL), one compiled pass, which
        # also counts l_1's pixels and bounds them.
        (low_a, high_a), (low_b, high_b) = self.extrema.parts()
        counted = keep_window_changes(delta1, image, low_a, low_b, high_a, high_b,
                                      tau, top, left, height, width)
        self.area, self.box = counted[0], counted[1:]
        return delta1


class DON:
    """The vision-to-motion optical network for one moving link.

    Args:
        fps: frame rate of the video, for rad/s.
        window: N, the frames in the input layer (paper: 10).
        gaussian: the Gaussian kernel size at 240 rows (paper: 15); 0, the default,
            for none beyond the area average to the working resolution (see the module
            docstring for why). Depth video wants `DEPTH_GAUSSIAN`.
        threshold: binarisation threshold of a difference, grey levels, in any colour
            channel.
        working_height: rows of the working resolution (see the module docstring).
        reference_direction: image-plane direction (rad, CCW from image right) of the
            fixed reference link; the joint angle is the link's direction minus this.
        pivot: the pivot in input pixels (x, y), if known; else estimated from the video.
        trust_threshold: below this eta (and where the link is hidden) the prediction
            layer takes over. Default 0, off: on the rendered scenarios it lowers the
            error on occluded frames a little but raises it over whole clips, where eta
            also drops wherever the tracker loses the link among moving clutter
            (benchmarks/RESULTS.md). eta is still computed and reported in every
            estimate; `imimic eval` scores occluded frames with prediction off and on.
        robot: a MuJoCo model of the robot, for torques; None gives zero torque.
        joint_range: the joint's (low, high) limits in rad, if known. Before the pivot is
            found, a moving region's axis gives the link's direction up to 180 degrees;
            a range narrower than that says which way it points. A reported angle is
            never past a limit (`geometry.within_range`).
        appearance: run the appearance layer (ours, `appearance.py`) after the paper's
            layers; False for the paper's layers alone.
        search_when_lost: where the motion layers have lost the link (it vanished while
            turning: ``hidden``), let the appearance layer look for its colour wherever
            the joint can turn, not only near its own last reading: it finds a forearm
            that comes out from behind an occluder and rests, which the motion layers do
            not see until it moves. On by default since the appearance layer stopped
            learning the wall's colour (`appearance.MAX_SHARE`): before that it jumped
            to whatever had that colour, and it lost on held-out clips as often as it
            won, by up to 32 degrees. Settled RMSE on development clips, off -> on,
            seeds 0-79 / 80-159 (`benchmarks/don_dev_seeds.py --param
            search_when_lost=False`): `exp3-forearm-high` 10.15 -> 8.72 deg (62 clips
            better, 6 worse) / 11.80 -> 10.39 (62 better, 13 worse; 95% interval of the
            change -2.3 to -0.5), `exp3-forearm-low` 5.82 -> 5.16 / 6.74 -> 5.59 (-1.6
            to -0.8), `exp3-forearm-none` 3.24 -> 3.03 / 2.91 -> 2.67,
            `exp1-noisy-fast` 12.99 -> 11.11 / 10.95 -> 9.14, `exp2-servo` and `default`
            unchanged; held-out seeds 1000-1009, once: `exp3-forearm-high` 12.95 ->
            13.73 (five clips better by up to 2.1, two worse by 4 and 9),
            `exp3-forearm-low` 12.21 -> 11.72 (one clip 25.1 -> 39.8, three 5-9
            better), `exp1-noisy-fast` 12.32 -> 9.40. What it still gets wrong is a
            colour like the link's where the link cannot be: the blurred edge between a
            brown board and the pale wall looks like skin (development clip 75 of
            `exp3-forearm-low`, 4.1 -> 12.6).
        min_area: fewest moving pixels (working resolution) that count as motion.
        reseek: leave rigid edges out and replace a pivot that a second estimate explains
            better (`geometry.LinkTracker`); False: the first pivot agreed is kept.
    """

    def __init__(
        self,
        fps: float = 30.0,
        window: int = 10,
        gaussian: int = 0,
        threshold: int = 8,
        working_height: int = 120,
        reference_direction: float = 0.0,
        pivot: tuple[float, float] | None = None,
        trust_threshold: float = 0.0,
        robot: mujoco.MjModel | None = None,
        min_area: int = 12,
        joint_range: tuple[float, float] | None = None,
        appearance: bool = True,
        search_when_lost: bool = True,
        reseek: bool = True,
    ) -> None:
        self.motion = MotionMask(window, gaussian, threshold, working_height)
        self.appearance = LinkAppearance() if appearance else None
        self.fps, self.window = float(fps), window
        self.reference_direction = reference_direction
        self.known_pivot = None if pivot is None else np.asarray(pivot, dtype=np.float64)
        self.trust_threshold, self.min_area = trust_threshold, min_area
        self.torque_model = TorqueModel(robot) if robot is not None else None
        self.joint_range = joint_range
        self.search_when_lost, self.reseek = search_when_lost, reseek
        self.reset()

    def reset(self) -> None:
        self.motion.reset()
        if self.appearance is not None:
            self.appearance.reset()
        self.read = False  # the motion layers read the link in the newest frame
        self.link: LinkTracker | None = None  # made on the first frame, once scale is known
        self.path = PathEstimator(1, self.fps, self.window)
        # M_p of the trust factor: the link's visible length per frame, None where the
        # frame measured nothing.
        self.sizes: deque[float | None] = deque(maxlen=self.window)
        self.angle: float | None = None  # absolute image angle of the link, rad
        self.predicting_for = 0  # frames the prediction layer has rolled on
        self.read_trust = 0.0  # eta at the last frame the motion layers read the link
        self.coast = 0.0  # its velocity, rad/frame
        self.hidden = False  # the link vanished while turning and has not been seen since
        self.missing = 0  # frames running without a reading of the link
        # Before the arm has moved DON has seen nothing: the middle of the joint's range
        # (if known) is the guess least far from anywhere the arm can be, and trust 0
        # says it is no reading (a controller should not chase it).
        start = (self.reference_direction if self.joint_range is None
                 else self.reference_direction + sum(self.joint_range) / 2)
        self.estimate = self._estimate(start, 0.0, 0.0, trust=0.0, predicted=False)
        self.last_mask: np.ndarray | None = None
        self.guess: float | None = None  # the last direction guessed before the pivot

    def move_pivot(self, pivot: tuple[float, float]) -> None:
        """The link's pivot is now at ``pivot`` (x, y input px): a known pivot that moved,
        as a pose model seeding DON reports it. The frames seen so far stay (the camera
        has not moved), so DON reads on without a new window."""
        self.known_pivot = np.asarray(pivot, dtype=np.float64)
        if self.link is not None:
            self.link.known_pivot = self.known_pivot / self.scale

    @property
    def scale(self) -> float:
        """Input pixels per working pixel."""
        return self.motion.scale

    @property
    def _tracker(self) -> LinkTracker:
        """The link's tracker, made on the first frame."""
        assert self.link is not None, "DON has seen no frame yet"
        return self.link

    # Layer 4b: trust factor -------------------------------------------------------------
    def trust_factor(self) -> float:
        """eta = 1 - max_p |M_1 - M_p| / max_p M_p, paper Eq. (TF); 1 with fewer than two
        measurements in the window, 0 when the link was hidden (size 0) in all of them.

        M_p is the link's visible length in frame p: how far from the pivot the moving
        regions accepted as the link reach (`LinkTracker.measure`). The paper takes M_p as
        the area of l_p, assuming "the size of the moving object will remain almost the
        same"; the area of a difference image does not (it grows with speed, so every
        start and stop of a movement would read as occlusion), while the reach of the
        link's moving pixels stays the link's length at any speed. An occluder hides part
        of it, and M_1 drops: a link whose outer half disappears gives eta = 0.5, the
        fraction still seen.
        """
        sizes = [m for m in self.sizes if m is not None]  # at most N floats: no numpy
        if len(sizes) < 2:
            return 1.0
        largest = max(sizes)
        if largest <= 0:
            return 0.0  # hidden for the whole window
        return 1.0 - max(abs(sizes[-1] - m) for m in sizes) / largest

    # Layer 5: prediction ------------------------------------------------------------------
    def _predict(self) -> float:
        """DON layer 5, prediction, paper Eq. (VAPr) with a braking acceleration (see the
        module docstring): roll the link on by one frame from the velocity it had when the
        prediction began (the mean of the last three v), shrinking by COAST_DECAY a frame;
        hold after N frames. Returns the predicted location (rad)."""
        assert self.angle is not None
        if self.predicting_for == 0:
            recent = list(self.path.V)[-3:]
            self.coast = sum(float(v[0]) for v in recent) / len(recent) if recent else 0.0
        self.predicting_for += 1
        if self.predicting_for > self.window:
            self.coast = 0.0
        self.coast *= COAST_DECAY
        return float(wrap_angle(self.angle + self.coast))

    def _estimate(self, angle: float, omega: float, alpha: float, trust: float,
                  predicted: bool) -> Estimate:
        q = within_range(float(wrap_angle(angle - self.reference_direction)), self.joint_range)
        angle = q + self.reference_direction  # the keypoints' direction, within the range too
        angles, omegas, alphas = np.array([q]), np.array([omega]), np.array([alpha])
        torque = (self.torque_model(angles, omegas, alphas) if self.torque_model is not None
                  else np.zeros(1))
        keypoints = self.link.keypoints(angle, self.scale) if self.link is not None else None
        return Estimate(angles=angles, omega=omegas, alpha=alphas, torque=torque,
                        trust=min(max(float(trust), 0.0), 1.0), predicted=predicted,
                        keypoints=keypoints)

    def _hold(self, trust: float) -> Reading | None:
        """Nothing to measure: the link stays where it was, at rest (the path estimator
        hears v = 0, so the next movement's omega does not start from the last one's).
        None (keep the last estimate) before there is a location to hold."""
        if self.angle is None:
            return None
        self.path.update((self.angle,))
        return Reading(self.angle, 0.0, 0.0, trust, predicted=False)

    def _was_turning_fast(self) -> bool:
        """Any of the path estimator's last three v exceeds VANISH_DEG a frame (the last
        alone can be the bogus reading of the frame the link vanished in)."""
        return any(abs(float(v[0])) > math.radians(VANISH_DEG) for v in list(self.path.V)[-3:])

    def _slow_reading(self) -> tuple[float, float] | None:
        """Where the link is when l_1 shows nothing along it: a link turning under a
        degree a frame moves too little between two frames, but not over half a window.
        The pixels the current frame differs from both N/2 and N frames back in are where
        the link is now and was in neither (where it was then differs from one of them
        only, once it has moved on by its width). None if those show no link either."""
        if self.hidden or self.angle is None or len(self.motion.history) <= self.window:
            return None
        link = self._tracker
        half = self.window // 2
        box = link.reach_box()
        mask = cv2.bitwise_and(self.motion.difference_to(half, box),
                               self.motion.difference_to(self.window, box))
        lines = component_lines(mask, self.min_area)
        pivot = link.pivot()
        assert pivot is not None  # read slowly only about a pivot
        return link.measure(lines, pivot, self.angle)

    def _link_missing(self, moved: bool) -> Reading | None:
        """No reading of the link in this frame: hold the last estimate. The link is
        hidden (size 0 in the trust factor, until it is seen again, resting or not) once
        it has been missing two frames running after turning faster than VANISH_DEG a
        frame: a link that fast cannot stop dead, and one frame without it is as often a
        reading that failed as an occluder. Otherwise the frame has no size: at rest,
        nothing to distrust where nothing ``moved``; where something did, eta as it
        stands."""
        self.missing += 1
        if self.missing >= 2 and self._was_turning_fast():
            self.hidden = True
        self.sizes.append(0.0 if self.hidden else None)
        trust = self.trust_factor() if self.hidden or moved else 1.0
        if (self.trust_threshold > 0 and self.angle is not None and self.path.V
                and (self.predicting_for > 0 or self.read_trust >= PREDICT_FROM_TRUST)):
            return self._predicted(trust)
        return self._hold(trust)

    def _scene_changed(self) -> Reading | None:
        """A frame that changed all over (`MotionMask.scene_changed`): trust 0 and the link
        held where it was, at rest; the path starts afresh from here, so the frames after
        a burst of noise carry no velocity from it. None before there is a location."""
        self.sizes.append(None)
        if self.angle is None:
            return None
        self.path.reset()
        self.path.update((self.angle,))
        return Reading(self.angle, 0.0, 0.0, 0.0, predicted=False)

    def _predicted(self, trust: float) -> Reading:
        """The reading from the prediction layer for this frame (`_predict`)."""
        self.angle = self._predict()
        self.path.update((self.angle,))
        omega = self.coast * self.fps
        return Reading(self.angle, omega, -(1 - COAST_DECAY) * omega * self.fps, trust,
                       predicted=True)

    def _before_pivot(self, lines: np.ndarray, mask: np.ndarray) -> Reading | None:
        """The reading until a pivot is agreed: the link's direction about the last
        solve's pivot where there is one (`PivotEstimator.provisional`), else the longest
        moving region's axis (`LinkTracker.before_pivot`); else None (the last estimate).

        The guesses feed the path estimator, so omega and alpha do not wait for the
        pivot (a guess GUESS_JUMP from the last restarts it), and the trust factor, with
        M_p the reach from the provisional pivot or else the region's extent along its
        axis: the paper's "size of the moving object". (Until this was measured, guesses
        were reported with eta 1, however much of the link an occluder hid.) The first
        reading about the agreed pivot starts the path afresh."""
        link = self._tracker
        provisional = link.pivots.provisional()
        reading = (None if provisional is None
                   else link.measure(lines, provisional, self.guess))
        if reading is None:
            reading = link.before_pivot(lines, mask)
        self.sizes.append(None if reading is None else reading[1])
        if reading is None:
            return None
        guess = reading[0]
        if self.guess is not None and abs(wrap_angle(guess - self.guess)) > GUESS_JUMP:
            self.path.reset()
        self.guess = guess
        self.path.update((guess,))
        return Reading(guess, float(self.path.omega()[0]), float(self.path.alpha()[0]),
                       self.trust_factor(), predicted=False)

    def update(self, frame: np.ndarray) -> Estimate:
        """Take the next (H, W, 3) uint8 RGB frame; return the estimate for it."""
        self.read = False
        reading = self._read_motion(frame)
        if reading is not None:
            if not self.motion.scene_changed:
                reading = self._read_appearance(reading)
            self.estimate = self._estimate(*reading)
        return self.estimate

    def _read_appearance(self, reading: Reading) -> Reading:
        """The appearance layer (`appearance.py`, ours): where it sees the link in this
        frame, its direction replaces the motion layers' location for this frame, in the
        path estimator too. Its reading is of the current frame, so no half-frame lead.
        The trust factor stays the motion layers' (paper Eq. TF)."""
        if self.appearance is None or self.angle is None:
            return reading
        link = self._tracker
        pivot = link.pivot()
        if pivot is None or link.radius is None:
            return reading
        angle = self.appearance.update(
            self.motion.history[-1], pivot, link.radius, prior=reading.angle,
            read=self.read, trust=reading.trust,
            directions=link.directions, lost=self.search_when_lost and self.hidden)
        if angle is None:
            return reading
        self.path.correct((angle,))
        self.angle = angle
        return Reading(angle, float(self.path.omega()[0]), float(self.path.alpha()[0]),
                       reading.trust, predicted=False)

    def _read_motion(self, frame: np.ndarray) -> Reading | None:
        """The paper's layers on the next frame: the reading from frame differences, or
        None where they give nothing new (the last estimate stands)."""
        mask = self.motion(frame)
        if mask is None:
            pivot = None if self.known_pivot is None else self.known_pivot / self.scale
            self.link = LinkTracker(self.reference_direction, pivot, self.joint_range,
                                    self.min_area, reach_back=REACH_BACK_PX,
                                    reseek=self.reseek)
            return None
        link = self._tracker
        self.last_mask = mask
        area = self.motion.area
        if self.motion.scene_changed:
            return self._scene_changed()

        measured = None
        if area < self.min_area:
            # Nothing moved: nothing to distrust, unless the link vanished (below).
            found = None if link.pivot() is None else self._slow_reading()
            if found is None:
                return self._link_missing(moved=False)
        else:
            lines = link.lines(mask, self.motion.box)
            pivot = link.pivot()
            if pivot is None:
                return self._before_pivot(lines, mask)
            # DON layer 3 + object regression: where the link is, from l_1's regions.
            measured = link.measure(lines, pivot, self.angle, mask)
            found = measured if measured is not None else self._slow_reading()
            if found is None:
                # Motion, but none along the link: the link is hidden (below), or at rest
                # while a distractor moves.
                return self._link_missing(moved=True)
        self.missing = 0
        self.read = True
        location, visible_length = found
        self.hidden = False
        self.sizes.append(visible_length)
        trust = self.trust_factor()
        self.read_trust = trust
        # The layer 4b switch: a low eta because this reading sees only part of the link,
        # not because an earlier frame in the window did (the link back in full view).
        partial = visible_length < PARTIAL * max(m for m in self.sizes if m is not None)
        if trust < self.trust_threshold and partial and self.angle is not None:
            return self._predicted(trust)
        # DON layer 4a: path estimator on the measured location. A jump no arm makes in a
        # frame is the link found again after a wrong or lost reading: its difference is
        # no velocity, so the path starts afresh from here.
        if self.angle is None or abs(wrap_angle(location - self.angle)) > MAX_TURN:
            self.path.reset()
        self.path.update((location,))
        self.angle = location
        self.predicting_for = 0
        omega, alpha = float(self.path.omega()[0]), float(self.path.alpha()[0])
        # delta1_1 spans frames t-1 and t: the location is half a frame old.
        current = self.angle + (0.5 * omega / self.fps if measured is not None else 0.0)
        return Reading(current, omega, alpha, trust, predicted=False)

    def run(self, frames: Iterable[np.ndarray]) -> list[Estimate]:
        """Estimates for every frame of an iterable (a clip's frames, a video reader)."""
        self.reset()
        return [self.update(frame) for frame in frames]
