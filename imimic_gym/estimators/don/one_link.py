"""DON, the paper's unsupervised vision-to-motion network (§3) for one moving link.

In: (H, W, 3) uint8 RGB frames (or depth as grey frames), one at a time (`DON.update`).
Out: per frame an `Estimate` with one joint: the angle (rad, from the reference
direction, CCW in the image), omega (rad/s), alpha (rad/s^2), torque (N m, the robot
model's inverse dynamics, else 0), the trust factor eta in [0, 1] and whether the
prediction layer gave it; keypoints (2, 2) input px (pivot, tip) once both are known.
From frame differences alone: no labels, no background model.

The layers: 1-3 `MotionMask` (l_1, the pixels that surely moved, paper Eq. OL); object
regression and location `LinkTracker` (a line per moving region; the pivot as the mode
of their crossings; s the weighted mean axis of the regions along rays from it); 4a the
path estimator (`motion.PathEstimator`, paper Eqs. V, A); 4b the trust factor (paper Eq.
TF, with M_p the link's visible length); 5 prediction (paper Eq. VAPr with a braking
acceleration, a = -(1 - ``coast_decay``) v). Then the appearance layer (ours,
`appearance.py`), which reads the link's direction from its colour in the current frame.
l_1 spans frames t-1 and t, so a location from it is half a frame old: the angle
reported is s + v / 2. Every knob is a field of `DONConfig`; where the paper is vague or
we differ from it, and why: `docs/decisions/` (`don-smoothing-and-threshold.md`,
`don-pivot.md`, `don-occluder-edges.md`, `don-prediction.md`, `don-appearance.md`,
`don-joint-limits.md`).
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Iterable
from typing import Any, NamedTuple

import cv2
import mujoco
import numpy as np

from imimic_gym.estimators.don.appearance import LinkAppearance
from imimic_gym.estimators.don.config import DONConfig, override
from imimic_gym.estimators.don.link_tracker import LinkTracker
from imimic_gym.estimators.don.motion_mask import MotionMask
from imimic_gym.estimators.don.regions import component_lines
from imimic_gym.estimators.frames import FrameShapeError
from imimic_gym.estimators.joint_range import within_range
from imimic_gym.estimators.motion import PathEstimator, TorqueModel
from imimic_gym.estimators.types import Estimate
from imimic_gym.kinematics import wrap_angle

__all__ = ["DON", "FrameShapeError"]


class Reading(NamedTuple):
    """One frame's reading before it becomes an `Estimate`: the link's image direction
    (rad), omega (rad/s), alpha (rad/s^2), eta, and whether the prediction layer gave it."""

    angle: float
    omega: float
    alpha: float
    trust: float
    predicted: bool



class DON:
    """The vision-to-motion optical network for one moving link.

    Args:
        fps: frame rate of the video, for rad/s.
        reference_direction: image-plane direction (rad, CCW from image right) of the
            fixed reference link; the joint angle is the link's direction minus this.
        pivot: the pivot in input pixels (x, y), if known; else estimated from the video.
        robot: a MuJoCo model of the robot, for torques; None gives zero torque.
        joint_range: the joint's (low, high) limits in rad, if known. Before the pivot is
            found, a moving region's axis gives the link's direction up to 180 degrees;
            a range narrower than that says which way it points. A reported angle is
            never past a limit (`joint_range.within_range`).
        config: the settings (`DONConfig`; `config.don_preset` gives the modality's).
        **settings: fields of `DONConfig` to override in ``config``, e.g.
            ``trust_threshold=0.3`` (prediction on) or ``appearance=False`` (the paper's
            layers alone).
    """

    def __init__(
        self,
        fps: float = 30.0,
        reference_direction: float = 0.0,
        pivot: tuple[float, float] | None = None,
        robot: mujoco.MjModel | None = None,
        joint_range: tuple[float, float] | None = None,
        config: DONConfig | None = None,
        **settings: Any,
    ) -> None:
        config = override(DONConfig() if config is None else config, settings)
        self.config = config
        self.motion = MotionMask(window=config.window, gaussian=config.gaussian,
                                 threshold=config.threshold,
                                 working_height=config.working_height,
                                 scene_change=config.scene_change)
        self.appearance = LinkAppearance(config.colour) if config.appearance else None
        self.fps, self.window = float(fps), config.window
        self.reference_direction = reference_direction
        self.known_pivot = None if pivot is None else np.asarray(pivot, dtype=np.float64)
        self.trust_threshold, self.min_area = config.trust_threshold, config.min_area
        self.torque_model = TorqueModel(robot) if robot is not None else None
        self.joint_range = joint_range
        self.search_when_lost, self.reseek = config.search_when_lost, config.reseek
        self._max_turn = math.radians(config.max_turn_deg)
        self._guess_jump = math.radians(config.guess_jump_deg)
        self.reset()

    def reset(self) -> None:
        self.motion.reset()
        if self.appearance is not None:
            self.appearance.reset()
        self.read = False  # the motion layers read the link in the newest frame
        self.appearance_read = False  # the appearance layer read it there
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
        prediction began (the mean of the last three v), shrinking by ``coast_decay`` a frame;
        hold after N frames. Returns the predicted location (rad)."""
        assert self.angle is not None
        if self.predicting_for == 0:
            recent = list(self.path.V)[-3:]
            self.coast = sum(float(v[0]) for v in recent) / len(recent) if recent else 0.0
        self.predicting_for += 1
        if self.predicting_for > self.window:
            self.coast = 0.0
        self.coast *= self.config.coast_decay
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
        """Any of the path estimator's last three v exceeds ``vanish_deg`` a frame (the last
        alone can be the bogus reading of the frame the link vanished in)."""
        vanish = math.radians(self.config.vanish_deg)
        return any(abs(float(v[0])) > vanish for v in list(self.path.V)[-3:])

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
        it has been missing two frames running after turning faster than ``vanish_deg`` a
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
                and (self.predicting_for > 0
                     or self.read_trust >= self.config.predict_from_trust)):
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
        return Reading(self.angle, omega, -(1 - self.config.coast_decay) * omega * self.fps, trust,
                       predicted=True)

    def _before_pivot(self, lines: np.ndarray, mask: np.ndarray) -> Reading | None:
        """The reading until a pivot is agreed: the link's direction about the last
        solve's pivot where there is one (`PivotEstimator.provisional`), else the longest
        moving region's axis (`LinkTracker.before_pivot`); else None (the last estimate).

        The guesses feed the path estimator, so omega and alpha do not wait for the
        pivot (a guess ``guess_jump_deg`` from the last restarts it), and the trust factor, with
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
        if self.guess is not None and abs(wrap_angle(guess - self.guess)) > self._guess_jump:
            self.path.reset()
        self.guess = guess
        self.path.update((guess,))
        return Reading(guess, float(self.path.omega()[0]), float(self.path.alpha()[0]),
                       self.trust_factor(), predicted=False)

    def update(self, frame: np.ndarray) -> Estimate:
        """Take the next (H, W, 3) uint8 RGB frame; return the estimate for it."""
        self.read = self.appearance_read = False
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
        self.appearance_read = True
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
                                    self.min_area, reach_back=self.config.reach_back_px,
                                    reseek=self.reseek, config=self.config.tracker)
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
        partial = visible_length < self.config.partial * max(
            m for m in self.sizes if m is not None)
        if trust < self.trust_threshold and partial and self.angle is not None:
            return self._predicted(trust)
        # DON layer 4a: path estimator on the measured location. A jump no arm makes in a
        # frame is the link found again after a wrong or lost reading: its difference is
        # no velocity, so the path starts afresh from here.
        if self.angle is None or abs(wrap_angle(location - self.angle)) > self._max_turn:
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
