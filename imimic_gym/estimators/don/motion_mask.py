"""DON layers 1-3 (paper §3): frames in, l_1 out, the pixels that surely moved.

In: (H, W, 3) uint8 RGB frames, one at a time. Layer 1 keeps the last N frames at the
working resolution (`frames.WorkingFrames`: area-averaged to ``working_height`` rows,
optionally Gaussian-smoothed). Layer 2 differences them, paper Eqs. (f1), (f2):
delta1_p = |f_{t-p+1} - f_{t-p}| for p = 1..N (so delta1_1 is the newest difference; the
paper's p = 0..N-1 needs f_{t+1}) and delta2_p = |f_t - f_{t-p}|, each binarised where any
channel exceeds ``threshold`` grey levels. Layer 3, paper Eq. (OL): l_1 = (union_p
delta2_p) & delta1_1, computed for the new frame only (l_2..l_N are the ones computed
when those frames were new). Out: (h, w) uint8 at the working resolution, nonzero where a
pixel moves, with its pixel count and bounding box.

The union of the N delta2 is incremental: |f_t - f_{t-p}| > tau for some p exactly when
f_t > min_p f_{t-p} + tau or f_t < max_p f_{t-p} - tau, and a sliding minimum and maximum
(van Herk / Gil-Werman, amortised O(1) images per frame) give both in two comparisons.
Shared by the one-link `DON` and `LinkedDON`; their settings: `config.py`.
"""

from __future__ import annotations

from collections import deque

import cv2
import numpy as np

from imimic_gym.estimators.don.compiled import keep_window_changes, running_extrema
from imimic_gym.estimators.frames import WorkingFrames

__all__ = ["MotionMask", "SlidingExtrema"]


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
        gaussian: the Gaussian kernel size at 240 rows (paper: 15; 0: none).
        threshold: binarisation threshold of a difference, grey levels, any channel.
        working_height: rows of the working resolution.
        scene_change: over this share of the working frame moving at once, the frame
            shows a cut, a flash or noise, not a link (`scene_changed`).
        name: the estimator's name, for error messages.
    """

    def __init__(self, *, window: int, gaussian: int, threshold: int, working_height: int,
                 scene_change: float, name: str = "DON") -> None:
        if window < 2:
            raise ValueError(f"window must be at least 2 frames, got {window}")
        self.frames = WorkingFrames(working_height, gaussian, name=name)
        self.window, self.threshold = window, threshold
        self.scene_change = scene_change
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
        """The newest frame changed over more than ``scene_change`` of the working frame:
        no link's motion, a cut, a flash or noise."""
        width, height = self.frames.size
        return self.area > self.scene_change * width * height

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
