"""Classical baselines behind DON's interface: the paper's comparison on equal terms.

Each finds moving pixels its own way, then shares everything else with DON: the same
working frames (`frames.py`), the same link geometry (`link_tracker.py`), the same path
estimator and torque model. Differences in accuracy are then differences in how the arm
is found, which is what the paper compared.

- `MOG2Estimator`: OpenCV's Gaussian-mixture background subtraction; the foreground is
  whatever differs from the learned background (the whole arm once it has moved).
- `CamShiftEstimator`: OpenCV's CamShift on a hue back-projection; the colour model is
  taken from the first region that moves, then tracked as a rotated rectangle.

Neither has a trust factor or a prediction layer (the paper's point): ``trust`` is 1
once they have read the link, and 0 before, while the angle is only a placeholder.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import cast

import cv2
import mujoco
import numpy as np

from imimic_gym.estimators.don.link_tracker import LinkTracker
from imimic_gym.estimators.frames import WorkingFrames
from imimic_gym.estimators.joint_range import within_range
from imimic_gym.estimators.motion import PathEstimator, TorqueModel
from imimic_gym.estimators.types import Estimate
from imimic_gym.kinematics import wrap_angle

__all__ = ["CamShiftEstimator", "MOG2Estimator"]


class _MaskEstimator:
    """Frames -> a mask of the moving arm (``_mask``, per subclass) -> link direction."""

    name = "estimator"

    def __init__(
        self,
        fps: float = 30.0,
        reference_direction: float = 0.0,
        joint_range: tuple[float, float] | None = None,
        robot: mujoco.MjModel | None = None,
        working_height: int = 120,
        gaussian: int = 15,
        min_area: int = 12,
    ) -> None:
        self.fps, self.reference_direction = float(fps), reference_direction
        self.joint_range, self.min_area = joint_range, min_area
        self.frames = WorkingFrames(working_height, gaussian, name=self.name)
        self.torque_model = TorqueModel(robot) if robot is not None else None
        self.reset()

    def reset(self) -> None:
        self.frames.reset()
        self.link: LinkTracker | None = None
        self.path = PathEstimator(1, self.fps)
        self.angle: float | None = None
        start = self.reference_direction + (sum(self.joint_range) / 2 if self.joint_range else 0)
        self.estimate = self._estimate(start, 0.0, 0.0, trust=0.0)  # no reading yet

    def _mask(self, image: np.ndarray) -> np.ndarray:
        raise NotImplementedError

    def _estimate(self, angle: float, omega: float, alpha: float,
                  trust: float = 1.0) -> Estimate:
        angles = np.array([within_range(float(wrap_angle(angle - self.reference_direction)),
                                        self.joint_range)])
        omegas, alphas = np.array([omega]), np.array([alpha])
        torque = (self.torque_model(angles, omegas, alphas) if self.torque_model is not None
                  else np.zeros(1))
        return Estimate(angles=angles, omega=omegas, alpha=alphas, torque=torque, trust=trust)

    def update(self, frame: np.ndarray) -> Estimate:
        """Take the next (H, W, 3) uint8 RGB frame; return the estimate for it."""
        image = self.frames(frame)
        if self.link is None:
            self.link = LinkTracker(self.reference_direction, None, self.joint_range,
                                    self.min_area, seek_every=10)
        lines = self.link.lines(self._mask(image))
        pivot = self.link.pivot()
        if pivot is None:
            guess = self.link.before_pivot(lines)
            if guess is not None:
                self.estimate = self._estimate(guess[0], 0.0, 0.0)
            return self.estimate
        measured = self.link.measure(lines, pivot, self.angle)
        if measured is None:
            # Nothing along the link: it holds, at rest, as in DON (the path estimator
            # hears v = 0, so the next movement's omega does not start from this one's).
            if self.angle is not None:
                self.path.update((self.angle,))
                self.estimate = self._estimate(self.angle, 0.0, 0.0)
            return self.estimate
        self.angle = measured[0]
        self.path.update((self.angle,))
        self.estimate = self._estimate(self.angle, float(self.path.omega()[0]),
                                       float(self.path.alpha()[0]))
        return self.estimate

    def run(self, frames: Iterable[np.ndarray]) -> list[Estimate]:
        """Estimates for every frame of an iterable."""
        self.reset()
        return [self.update(frame) for frame in frames]


class MOG2Estimator(_MaskEstimator):
    """Background subtraction (OpenCV MOG2, no shadow detection) finds the moving arm."""

    name = "MOG2"

    def reset(self) -> None:
        super().reset()
        self.subtractor = cv2.createBackgroundSubtractorMOG2(detectShadows=False)

    def _mask(self, image: np.ndarray) -> np.ndarray:
        return self.subtractor.apply(image) > 0

    # OpenCV's subtractor cannot be pickled or deep-copied (gymnasium deep-copies a
    # wrapper's arguments to record its spec; vector envs pickle them): a copy starts a
    # new background model, as after `reset`.
    def __getstate__(self) -> dict:
        state = self.__dict__.copy()
        state.pop("subtractor", None)
        return state

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)
        self.subtractor = cv2.createBackgroundSubtractorMOG2(detectShadows=False)


class CamShiftEstimator(_MaskEstimator):
    """CamShift follows the hue of the first region that moves; its rotated rectangle is
    the arm. Until something moves, there is nothing to follow."""

    name = "CamShift"
    criteria = (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 10, 1)

    def reset(self) -> None:
        super().reset()
        self.previous: np.ndarray | None = None
        self.histogram: np.ndarray | None = None
        self.window: tuple[int, int, int, int] | None = None

    def _start(self, image: np.ndarray, previous: np.ndarray, hsv: np.ndarray) -> None:
        """Take the colour model from the largest region that changed since the last frame
        (``previous``)."""
        moving = cv2.absdiff(image, previous).max(axis=2) > 20
        count, _, stats, _ = cv2.connectedComponentsWithStats(moving.view(np.uint8))
        if count < 2 or stats[1:, cv2.CC_STAT_AREA].max() < self.min_area:
            return
        largest = 1 + int(np.argmax(stats[1:, cv2.CC_STAT_AREA]))
        x, y, w, h = (int(v) for v in stats[largest, :4])
        roi = hsv[y:y + h, x:x + w]
        valid = cv2.inRange(roi, (0, 30, 30), (180, 255, 255))
        self.histogram = cv2.calcHist([roi], [0], valid, [32], [0, 180])
        cv2.normalize(self.histogram, self.histogram, 0, 255, cv2.NORM_MINMAX)
        self.window = (x, y, max(w, 2), max(h, 2))

    def _mask(self, image: np.ndarray) -> np.ndarray:
        hsv = cv2.cvtColor(image, cv2.COLOR_RGB2HSV)
        mask = np.zeros(image.shape[:2], dtype=bool)
        if self.histogram is None or self.window is None:  # set together by _start
            if self.previous is not None:
                self._start(image, self.previous, hsv)
            self.previous = image
            return mask
        back = cv2.calcBackProject([hsv], [0], self.histogram, [0, 180], 1)
        box, window = cv2.CamShift(back, self.window, self.criteria)
        self.window = cast(tuple[int, int, int, int], window)  # a tuple; the stub says Sequence
        if self.window[2] < 2 or self.window[3] < 2:  # lost: start again on new motion
            self.histogram, self.window = None, None
            return mask
        corners = cv2.boxPoints(box).astype(np.int32)
        cv2.fillConvexPoly(mask.view(np.uint8), corners, 1)
        return mask
