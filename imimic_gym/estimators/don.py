"""DON, the paper's unsupervised vision-to-motion network (§3), one layer per unit.

Frames in, joint angle, angular velocity, acceleration and torque out, from frame
differences alone: no labels, no background model.

Decisions where the paper is vague or inconsistent (each is also noted where it acts):

- Working resolution. Every layer runs on the frame area-averaged down to
  ``working_height`` rows (120: half of the paper's 240x320), with the paper's 15x15
  Gaussian scaled by the same factor (7x7, sigma halved). That is the same smoothing in
  scene units at a quarter of the pixels, and keeps DON's cost almost independent of the
  input resolution. Angles are scale-free; pixel outputs are scaled back.
- Difference indices. The paper's Eq. (f1) runs p = 0..N-1 and so needs f_{t+1}; we use
  delta1_p = |f_{t-p+1} - f_{t-p}|, p = 1..N, so delta1_1 is the newest difference.
- Incremental union. |f_t - f_{t-p}| > tau for some p exactly when f_t > min_p f_{t-p} +
  tau or f_t < max_p f_{t-p} - tau. A sliding minimum and maximum over the N previous
  frames (van Herk / Gil-Werman, amortised O(1) images per frame) give the union of the
  N delta2 in two comparisons instead of N differences.
- Object identification per frame. l_1 = (union delta2) & delta1_1 is computed for the
  new frame; the locations and areas of l_2..l_N are the ones computed when those frames
  were new. Re-intersecting older delta1 with today's union only drops noise pixels.
- Pivot and radius. The link turns about a pivot that never moves, so every frame's
  moving region is elongated along a line through it. The pivot is the least-squares
  intersection of those lines (principal axes of l_1), accumulated with slow forgetting;
  the paper never says how it finds the pivot. The radius r (skeleton length) is a high
  percentile of the moving pixels' distance from the pivot along the link.
- Location. s = the link's angle about the pivot: the peak of a radius-weighted polar
  histogram of l_1's pixels, refined by their weighted mean near the peak. A blob that is
  not on a ray through the pivot (a distractor) spreads over many bins and loses.
  delta1_1 spans frames t-1 and t, so s lags by half a frame: the angle reported for
  frame t is s + v/2.
- Trust and prediction. eta per Eq. (TF). Below ``trust_threshold`` the current frame is
  not believed and the prediction layer rolls the last trusted state forward with
  Eq. (VAPr), v <- v + a, a <- a + a', for at most 2N frames (the paper's set length),
  then holds. A frame with no motion at all keeps the last estimate and eta = 1
  ("nothing to distrust"). Nothing here can produce NaN.
"""

from __future__ import annotations

import math
from collections import deque

import cv2
import mujoco
import numpy as np

from imimic_gym.estimators.motion import PathEstimator, TorqueModel
from imimic_gym.estimators.types import Estimate
from imimic_gym.metrics import wrap_angle

__all__ = ["DON", "FrameShapeError"]


class FrameShapeError(ValueError):
    """A frame is not (H, W, 3) uint8, or differs in size from the clip's first frame."""


_ONES = np.ones((1, 3), dtype=np.float32)


def _channel_sum(image: np.ndarray) -> np.ndarray:
    """(H, W) uint8 sum of the 3 channels, saturating at 255: one OpenCV pass."""
    return cv2.transform(image, _ONES)


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

    def extrema(self) -> tuple[np.ndarray, np.ndarray]:
        """(min, max) over the last N pushed images (fewer at the start)."""
        k = len(self.block)
        if k == 0:
            return self.suffix_min[0], self.suffix_max[0]
        if not self.suffix_min:
            return self.run_min, self.run_max
        return (cv2.min(self.suffix_min[k], self.run_min) if k < self.n else self.run_min,
                cv2.max(self.suffix_max[k], self.run_max) if k < self.n else self.run_max)

    def push(self, image: np.ndarray) -> None:
        if self.block:
            self.run_min = cv2.min(self.run_min, image)
            self.run_max = cv2.max(self.run_max, image)
        else:
            self.run_min, self.run_max = image, image
        self.block.append(image)
        if len(self.block) == self.n:
            lows, highs = [self.block[-1]], [self.block[-1]]
            for img in reversed(self.block[:-1]):
                lows.append(cv2.min(lows[-1], img))
                highs.append(cv2.max(highs[-1], img))
            self.suffix_min, self.suffix_max = lows[::-1], highs[::-1]
            self.block, self.run_min, self.run_max = [], None, None

    @property
    def empty(self) -> bool:
        return not self.block and not self.suffix_min


def component_lines(mask: np.ndarray, min_area: int) -> np.ndarray:
    """Principal axis of every 8-connected component of ``mask`` with at least
    ``min_area`` pixels, from its second moments in one vectorised pass.

    Returns (k, 7) float64 rows: centre x, centre y, direction x, direction y, length (std
    along the axis, px), elongation (major/minor std ratio), area (px).
    """
    count, labels = cv2.connectedComponents(mask.view(np.uint8), connectivity=8)
    ys, xs = np.nonzero(mask)
    label = labels[ys, xs]
    n = np.bincount(label, minlength=count).astype(np.float64)
    keep = n >= max(min_area, 2)
    keep[0] = False
    if not keep.any():
        return np.zeros((0, 7))
    x, y = xs.astype(np.float64), ys.astype(np.float64)
    sx, sy = np.bincount(label, x, count), np.bincount(label, y, count)
    sxx, syy = np.bincount(label, x * x, count), np.bincount(label, y * y, count)
    sxy = np.bincount(label, x * y, count)
    n, sx, sy, sxx, syy, sxy = (v[keep] for v in (n, sx, sy, sxx, syy, sxy))
    cx, cy = sx / n, sy / n
    a, c, b = sxx / n - cx**2, syy / n - cy**2, sxy / n - cx * cy
    half_gap = np.sqrt(((a - c) / 2) ** 2 + b**2)
    major, minor = (a + c) / 2 + half_gap, np.maximum((a + c) / 2 - half_gap, 1e-9)
    theta = 0.5 * np.arctan2(2 * b, a - c)
    return np.stack([cx, cy, np.cos(theta), np.sin(theta), np.sqrt(major),
                     np.sqrt(major / minor), n], axis=1)


class PivotEstimator:
    """The point where the link's lines meet: the mode of the pairwise intersections of
    the last ``memory`` lines. Lines of the turning link all cross at the pivot; lines of
    anything else (a distractor, a blob elongated along the motion) cross anywhere, so
    they spread out and do not move the mode."""

    def __init__(self, memory: int = 60, refresh: int = 5) -> None:
        self.lines: deque[np.ndarray] = deque(maxlen=memory)
        self.refresh, self._new = refresh, 0
        self._cached: np.ndarray | None = None
        self._last: np.ndarray | None = None

    def add_line(self, line: np.ndarray) -> None:
        """``line``: a row of `component_lines` (centre, direction, length, elongation).
        The pivot is solved again every ``refresh`` new lines: it does not move, and one
        solve (all pairs of up to 60 lines) costs as much as the rest of a frame."""
        self.lines.append(line)
        self._new += 1
        if self._new >= self.refresh or self._last is None:
            self._cached, self._new = None, 0

    def pivot(self) -> np.ndarray | None:
        """The densest point of the intersections of line pairs that cross at more than
        10 degrees, once 20 such pairs exist; before that, the last pivot (or None)."""
        if self._cached is not None or len(self.lines) < 6:
            return self._cached if self._cached is not None else self._last
        lines = np.array(self.lines)
        centre, direction, weight = lines[:, 0:2], lines[:, 2:4], lines[:, 4]
        i, j = np.triu_indices(len(lines), k=1)
        cross = direction[i, 0] * direction[j, 1] - direction[i, 1] * direction[j, 0]
        good = np.abs(cross) > math.sin(math.radians(10))
        if np.count_nonzero(good) < 20:
            return self._last
        i, j, cross = i[good], j[good], cross[good]
        delta = centre[j] - centre[i]
        along_i = (delta[:, 0] * direction[j, 1] - delta[:, 1] * direction[j, 0]) / cross
        points = centre[i] + along_i[:, None] * direction[i]
        weights = weight[i] * weight[j]
        point = np.array([np.median(points[:, 0]), np.median(points[:, 1])])
        for radius in (16.0, 8.0, 4.0, 4.0):  # shrinking mean shift toward the mode
            near = np.hypot(*(points - point).T) < radius
            if not near.any():
                break
            point = np.average(points[near], axis=0, weights=weights[near])
        self._cached = self._last = point
        return point


class DON:
    """The vision-to-motion optical network for one moving link.

    Args:
        fps: frame rate of the video, for rad/s.
        window: N, the frames in the input layer (paper: 10).
        gaussian: the paper's Gaussian kernel size at 240 rows (paper: 15).
        threshold: binarisation threshold of a difference: the sum over the three colour
            channels, in grey levels.
        working_height: rows of the working resolution (see the module docstring).
        reference_direction: image-plane direction (rad, CCW from image right) of the
            fixed reference link; the joint angle is the link's direction minus this.
        pivot: the pivot in input pixels (x, y), if known; else estimated from the video.
        trust_threshold: below this eta the prediction layer takes over. Default 0, off:
            on the rendered scenarios eta does not yet separate occlusion from ordinary
            changes of speed, and switching to prediction on it raised the angle error
            (measured: exp2-servo 0.5 -> 1.5 degrees at 0.3). eta is still computed and
            reported in every estimate.
        robot: a MuJoCo model of the robot, for torques; None gives zero torque.
        joint_range: the joint's (low, high) limits in rad, if known. Before the pivot is
            found, a moving region's axis gives the link's direction up to 180 degrees;
            a range narrower than that says which way it points.
        min_area: fewest moving pixels (working resolution) that count as motion.
    """

    n_links = 1

    def __init__(
        self,
        fps: float = 30.0,
        window: int = 10,
        gaussian: int = 15,
        threshold: int = 20,
        working_height: int = 120,
        reference_direction: float = 0.0,
        pivot: tuple[float, float] | None = None,
        trust_threshold: float = 0.0,
        robot: mujoco.MjModel | None = None,
        min_area: int = 12,
        joint_range: tuple[float, float] | None = None,
    ) -> None:
        if window < 2:
            raise ValueError(f"window must be at least 2 frames, got {window}")
        if gaussian < 1 or gaussian % 2 == 0:
            raise ValueError(f"gaussian must be an odd kernel size, got {gaussian}")
        self.fps, self.window, self.gaussian = float(fps), window, gaussian
        self.threshold, self.working_height = threshold, working_height
        self.reference_direction = reference_direction
        self.known_pivot = None if pivot is None else np.asarray(pivot, dtype=np.float64)
        self.trust_threshold, self.min_area = trust_threshold, min_area
        self.torque_model = TorqueModel(robot) if robot is not None else None
        self.joint_range = joint_range
        self.reset()

    def reset(self) -> None:
        self.shape: tuple[int, ...] | None = None
        self.scale = 1.0
        self.previous: np.ndarray | None = None
        self.extrema = SlidingExtrema(self.window)
        self.pivots = PivotEstimator()
        self.path = PathEstimator(1, self.fps, self.window)
        self.areas: deque[float | None] = deque(maxlen=self.window)
        self.radius: float | None = None
        self._radius_pivot: np.ndarray | None = None
        self.angle: float | None = None  # absolute image angle of the link, rad
        self.measured: float | None = None  # the last angle measured, not predicted
        self.predicting_for = 0
        self.lost_for = 0
        # Before the arm has moved DON has seen nothing: the middle of the joint's range
        # (if known) is the guess least far from anywhere the arm can be.
        start = (self.reference_direction if self.joint_range is None
                 else self.reference_direction + sum(self.joint_range) / 2)
        self.estimate = self._estimate(start, 0.0, 0.0, trust=1.0, predicted=False)
        self.last_mask: np.ndarray | None = None

    # Layer 1: input -------------------------------------------------------------------
    def _prepare(self, frame: np.ndarray) -> np.ndarray:
        """Area-averaged to the working resolution, Gaussian-smoothed, still in colour:
        skin against a pale wall differs little in grey but a lot in blue."""
        if not isinstance(frame, np.ndarray) or frame.dtype != np.uint8 or frame.ndim != 3 \
                or frame.shape[2] != 3:
            got = (f"{frame.shape} {frame.dtype}" if isinstance(frame, np.ndarray)
                   else type(frame).__name__)
            raise FrameShapeError(f"DON takes (H, W, 3) uint8 RGB frames, got {got}")
        if self.shape is None:
            self.shape = frame.shape
            self.scale = frame.shape[0] / min(self.working_height, frame.shape[0])
            size = (max(1, round(frame.shape[1] / self.scale)),
                    max(1, round(frame.shape[0] / self.scale)))
            self.working_size = size
            # The paper's kernel is for 240 rows; scale it to the working rows.
            kernel = max(1, round(self.gaussian * self.working_size[1] / 240))
            self.kernel = kernel + 1 - kernel % 2
        elif frame.shape != self.shape:
            raise FrameShapeError(
                f"frame is {frame.shape}, but this clip's frames are {self.shape}; "
                "call reset() before a clip of another size"
            )
        if self.scale != 1.0:
            frame = cv2.resize(frame, self.working_size, interpolation=cv2.INTER_AREA)
        return cv2.GaussianBlur(frame, (self.kernel, self.kernel), 0)

    # Layers 2 and 3: frame differences and object identification ----------------------
    def _moving_pixels(self, image: np.ndarray) -> np.ndarray:
        """l_1 = (union_p delta2_p) & delta1_1 (paper Eq. OL), binary uint8."""
        tau = self.threshold
        # DON layer 2: frame difference, paper Eqs. (f1), (f2), binarised.
        # A pixel differs when its colour channels differ by more than tau in sum (L1).
        delta1 = _channel_sum(cv2.absdiff(image, self.previous)) > tau
        low, high = self.extrema.extrema()
        union = (_channel_sum(cv2.subtract(image, low)) > tau) | (
            _channel_sum(cv2.subtract(high, image)) > tau)
        # DON layer 3: object identification, paper Eq. (OL).
        return delta1 & union

    def _pivot(self) -> np.ndarray | None:
        if self.known_pivot is not None:
            return self.known_pivot / self.scale
        return self.pivots.pivot()

    def _link_angle(self, lines: np.ndarray, pivot: np.ndarray) -> tuple[float, float] | None:
        """The location s: the link's direction (rad, CCW, image up), from the moving
        regions that lie along a ray from the pivot, and those regions' area (px).

        A region belongs to the link when it is clearly elongated and its principal axis
        points at the pivot within ~14 degrees (it lies along a ray: the link's leading and
        trailing slivers do, a distractor's blob seldom does), it is no farther than 1.6
        link radii, and it lies within 45 degrees of the last direction (a gate dropped
        after 5 frames without a match, so a wrong lock cannot last). The direction is the
        mean of those regions' axes weighted by length times area, pointed away from the
        pivot: an axis does not tilt when the pivot is a few pixels off, as a
        pivot-to-pixel angle would.
        """
        if len(lines) == 0:
            return None
        centre, direction = lines[:, 0:2], lines[:, 2:4]
        length, area = lines[:, 4], lines[:, 6]
        offset = centre - pivot
        distance = np.hypot(offset[:, 0], offset[:, 1])
        miss = np.abs(offset[:, 0] * direction[:, 1] - offset[:, 1] * direction[:, 0])
        # Along a ray from the pivot within ~14 degrees, and clearly elongated: a round blob
        # (a ball, a fist turning) says nothing about a direction.
        keep = (miss < np.maximum(4.0, 0.25 * distance)) & (distance > 2.0)
        keep &= (length > 2.5) & (lines[:, 5] > 2.0)
        if self.radius is not None:
            keep &= distance < 1.6 * self.radius
        centre_angle = np.arctan2(-offset[:, 1], offset[:, 0])  # image y points down
        if self.angle is not None and self.lost_for < 5:
            keep &= np.abs(wrap_angle(centre_angle - self.angle)) < math.radians(45)
        if not keep.any():
            self.lost_for += 1
            return None
        self.lost_for = 0
        # Axes point from the pivot outward; y flips to the CCW, image-up convention.
        outward = np.where((np.einsum("ij,ij->i", direction, offset) < 0)[:, None],
                           -direction, direction)[keep]
        angles = np.arctan2(-outward[:, 1], outward[:, 0])
        weights = (length * area)[keep]
        mean = math.atan2(float(np.sum(weights * np.sin(angles))),
                          float(np.sum(weights * np.cos(angles))))
        reach = float(np.max(distance[keep] + 1.7 * length[keep]))
        self.radius = reach if self.radius is None else 0.9 * self.radius + 0.1 * reach
        return mean, float(area[keep].sum())

    # Layer 4b: trust factor -------------------------------------------------------------
    def trust_factor(self) -> float:
        """eta = 1 - max_p |M_1 - M_p| / max_p M_p, paper Eq. (TF); 1 with fewer than two
        measurements in the window.

        M_p is the link's visible size: its moving area divided by the angle it turned
        in that frame. The paper assumes "the size of the moving object will remain almost
        the same"; the raw area of a difference image does not (it grows with speed, so
        every start and stop of a movement would read as occlusion), but area per radian
        does: a link of visible length L sweeps about L^2 per radian. An occluder hides
        part of L, and M_p drops. Frames turning less than half a degree are left out.
        """
        areas = np.asarray([a for a in self.areas if a is not None], dtype=np.float64)
        largest = areas.max() if areas.size > 1 else 0.0
        if largest <= 0:
            return 1.0
        return float(1.0 - np.max(np.abs(areas[-1] - areas)) / largest)

    # Layer 5: prediction ------------------------------------------------------------------
    def _predict(self) -> float:
        """Roll the last trusted state on by one frame, paper Eq. (VAPr)."""
        assert self.angle is not None
        if self.predicting_for >= 2 * self.window or len(self.path.V) < 3:
            return self.angle  # the paper's sets end at 2N elements: hold from here
        V, A = np.array(self.path.V), np.array(self.path.A)
        jerk = A[-1] - A[-2]
        # Eq. (VAPr), bounded by the largest v and a the window has seen: a cubic
        # extrapolation left alone runs away within a few frames.
        v_max, a_max = np.abs(V).max(axis=0), np.abs(A).max(axis=0)
        v = np.clip(V[-1] + A[-2], -v_max, v_max)
        a = np.clip(A[-1] + jerk, -a_max, a_max)
        self.path.V.append(v)
        self.path.A.append(a)
        self.path.location = np.array([self.angle + float(v[0])])
        return self.angle + float(v[0])

    def _estimate(self, angle: float, omega: float, alpha: float, trust: float,
                  predicted: bool) -> Estimate:
        q = float(wrap_angle(angle - self.reference_direction))
        angles, omegas, alphas = np.array([q]), np.array([omega]), np.array([alpha])
        torque = (self.torque_model(angles, omegas, alphas) if self.torque_model is not None
                  else np.zeros(1))
        keypoints = None
        pivot = self._pivot() if self.previous is not None else None
        if pivot is not None and self.radius is not None:
            tip = pivot + self.radius * np.array([math.cos(angle), -math.sin(angle)])
            keypoints = np.stack([pivot, tip]) * self.scale
        return Estimate(angles=angles, omega=omegas, alpha=alphas, torque=torque,
                        trust=float(np.clip(trust, 0.0, 1.0)), predicted=predicted,
                        keypoints=keypoints)

    def _before_pivot(self, lines: np.ndarray) -> Estimate:
        """Until the pivot is found: the longest elongated region's axis, pointed by the
        joint range (if known); else hold."""
        if self.joint_range is None or len(lines) == 0:
            return self.estimate
        candidates = lines[(lines[:, 5] > 2.0) & (lines[:, 4] > 2.5)]
        if len(candidates) == 0:
            return self.estimate
        line = candidates[np.argmax(candidates[:, 4] * candidates[:, 6])]
        axis = math.atan2(-line[3], line[2])  # CCW, image up
        lo, hi = self.joint_range
        middle = self.reference_direction + (lo + hi) / 2
        if abs(wrap_angle(axis - middle)) > math.pi / 2:
            axis += math.pi
        self.estimate = self._estimate(float(wrap_angle(axis)), 0.0, 0.0, trust=1.0,
                                       predicted=False)
        return self.estimate

    def update(self, frame: np.ndarray) -> Estimate:
        """Take the next (H, W, 3) uint8 RGB frame; return the estimate for it."""
        image = self._prepare(frame)
        if self.previous is None:
            self.previous = image
            self.extrema.push(image)
            return self.estimate
        mask = self._moving_pixels(image)
        self.last_mask = mask
        self.previous = image
        self.extrema.push(image)
        area = int(np.count_nonzero(mask))

        if area < self.min_area:
            self.areas.append(None)
            # No motion: hold the last estimate (nothing moved, nothing to distrust).
            if self.angle is not None:
                self.estimate = self._estimate(self.angle, 0.0, 0.0, trust=1.0, predicted=False)
            return self.estimate

        lines = component_lines(mask, self.min_area)
        if self.known_pivot is None:
            for line in lines:
                if line[5] > 1.4 and line[4] > 3.0:
                    self.pivots.add_line(line)
        pivot = self._pivot()
        if pivot is None:
            return self._before_pivot(lines)
        if self._radius_pivot is None or np.hypot(*(pivot - self._radius_pivot)) > 2.0:
            self.radius, self._radius_pivot = None, pivot  # r was measured from elsewhere

        measured = self._link_angle(lines, pivot)
        if measured is None:
            self.areas.append(None)
            # Motion, but none along the link (a distractor while the arm rests): hold.
            if self.angle is not None:
                self.path.update(np.array([self.angle]))
                self.estimate = self._estimate(self.angle, 0.0, 0.0, self.trust_factor(),
                                               False)
            return self.estimate
        location, link_area = measured
        turned = (abs(float(wrap_angle(location - self.measured)))
                  if self.measured is not None else 0.0)
        self.measured = location
        self.areas.append(link_area / turned if turned > math.radians(0.5) else None)
        trust = self.trust_factor()
        predicted = trust < self.trust_threshold and self.angle is not None
        if predicted:
            self.angle = self._predict()
            self.predicting_for += 1
        else:
            # DON layer 4a: path estimator on the measured location.
            self.path.update(np.array([location]))
            self.angle = location
            self.predicting_for = 0
        omega, alpha = float(self.path.omega()[0]), float(self.path.alpha()[0])
        # delta1_1 spans frames t-1 and t: the location is half a frame old.
        current = self.angle + 0.5 * omega / self.fps
        self.estimate = self._estimate(current, omega, alpha, trust, predicted)
        return self.estimate

    def run(self, frames) -> list[Estimate]:
        """Estimates for every frame of an iterable (a clip's frames, a video reader)."""
        self.reset()
        return [self.update(frame) for frame in frames]
