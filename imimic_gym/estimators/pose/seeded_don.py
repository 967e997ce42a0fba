"""Pose-seeded DON (registry name ``pose-don``): the pose model places DON on the forearm
and reads the arm every few frames; DON carries the forearm between those frames.

The pose model (`pose.PoseEstimator.read`) costs some 17-20 ms a frame on 2 CPU cores,
DON about 1 ms on a small crop. So the pose model reads every ``pose_every``-th frame
and no other while it sees the arm (every frame while it does not: nothing to carry);
while it sees the arm, that bounds the cost per frame at about a fifth of the pose
model's at the default 5.

From a pose reading DON gets its pivot (the elbow), its reference direction (the upper
arm) and its working area: a square crop about the elbow of ``REACH`` forearm lengths a
side, resized to ``CROP`` px (in a 1920x1080 frame a forearm is a few pixels of a whole
frame at DON's 120 rows; on the crop it is half its height). DON reads every frame of
the crop.

Between pose frames the estimate is the angle at an anchor turned by as much as DON saw
the forearm turn since; the anchor is the pose frame, or the first frame since on which
DON read the forearm. Only DON's turns are used: its own direction can be off by a
steady bias. DON's eta does not gate them (its turns help even where the link's reach
varies, and the next pose frame checks them). Where DON has no reading (no link found
yet, layer 5's prediction, or a turn over ``MAX_STEP`` in a frame), the last estimate
rolls on at the turn rate between the last two pose frames. The estimate's trust is the
pose model's on its last frame.

On a pose frame the estimate moves ``GAIN`` of the way from the angle carried to this
frame to the pose model's reading: the model's keypoints jitter, DON's turns do not. A
reading over ``DISAGREE`` from the carried angle is taken as it is (the arm moved faster
than the carry followed: a new place, not jitter), with no turn rate, unless the pose
frame before was such a jump at a like rate (a fast steady turn: it rolls on at it); so
is the first reading, and the other arm's. DON's pivot moves to the elbow the pose model
sees (`DON.move_pivot`, keeping DON's frames). DON is seeded afresh, on a new crop, when
the elbow is over ``MOVE`` forearm lengths off the crop's centre or the forearm's length
changed by over ``SCALE`` (the person moved), or when DON's turns carried the estimate
over ``DISAGREE`` away from the pose model's reading (DON followed something else).
Nobody in view: trust 0, the angle held, as `PoseEstimator`. Why these values:
``docs/decisions/pose-don.md``.
"""

from __future__ import annotations

import math
from dataclasses import replace

import cv2
import mujoco
import numpy as np

from imimic_gym.estimators.don.one_link import DON
from imimic_gym.estimators.motion import PathEstimator, TorqueModel
from imimic_gym.estimators.pose.model import PoseModel
from imimic_gym.estimators.pose.planar import (
    ELBOW_RANGE,
    ArmReading,
    PoseEstimator,
    continue_within,
)
from imimic_gym.estimators.types import Estimate
from imimic_gym.kinematics import wrap_angle

__all__ = ["CROP", "PoseSeededDON"]

CROP = 120  # px a side of the crop DON reads: its working height, so no further scaling
REACH = 3.2  # the crop's side in forearm lengths: the forearm fits whichever way it points
MIN_SIDE = 32.0  # input px: the smallest crop
MOVE = 0.5  # elbow shift off the crop's centre, in forearm lengths, that re-seeds DON
SCALE = 0.5  # relative change of the forearm's length that re-seeds DON
# A pose reading further than this from the carried angle is taken as it is, and DON is
# re-seeded if its turns carried the angle there.
DISAGREE = math.radians(20.0)
# DON's reading that turns the forearm further than this from the last frame's estimate
# is not taken (an elbow at 450 deg/s turns 15 deg a frame at 30 fps).
MAX_STEP = math.radians(15.0)
# On a pose frame the estimate moves this share of the way from the angle carried by DON
# (or rolled on) to the pose model's reading: the model's keypoints jitter from frame to
# frame, DON's turns do not.
GAIN = 0.7


def _alike(rate: float, before: float | None) -> bool:
    """Two turn rates (rad a frame) of the same sign within a factor of two."""
    return before is not None and rate * before > 0 and 0.5 <= rate / before <= 2.0


def _direction(start: np.ndarray, end: np.ndarray) -> float:
    """Image direction from ``start`` to ``end`` (x, y px), rad CCW from image right."""
    return math.atan2(-(end[1] - start[1]), end[0] - start[0])


class PoseSeededDON:
    """DON on a crop about the elbow, seeded and re-seeded by the pose model: one link,
    the forearm about the elbow, angles as `PoseEstimator` gives them.

    Args:
        fps: frame rate, for rad/s.
        reference_direction: unused by one link (the upper arm is the reference); kept so
            the registry builds every estimator alike.
        arm, min_confidence: as `PoseEstimator`.
        pose_every: the pose model reads every this many frames (every frame while it
            sees no arm).
        window: DON's window N (frames).
        robot: the robot's MuJoCo model, for torques; None gives zero torque.
        model: a `PoseModel` to use (None: a new one, in video mode).
    """

    def __init__(self, fps: float = 30.0, reference_direction: float = -math.pi / 2,
                 arm: str = "auto", min_confidence: float = 0.5, pose_every: int = 5,
                 window: int = 10, robot: mujoco.MjModel | None = None,
                 model: PoseModel | None = None) -> None:
        if not (isinstance(pose_every, int) and pose_every >= 1):
            raise ValueError(f"pose_every must be a whole number of frames >= 1, "
                             f"got {pose_every!r}")
        self.pose = PoseEstimator(n_links=1, fps=fps, reference_direction=reference_direction,
                                  arm=arm, min_confidence=min_confidence, model=model)
        self.fps, self.pose_every, self.window = float(fps), pose_every, window
        self.torque_model = TorqueModel(robot) if robot is not None else None
        self.reset()

    def reset(self) -> None:
        self.pose.reset()
        self.path = PathEstimator(1, self.fps)
        self.frame = 0
        self.since_pose = 0  # frames since the pose model last read one
        self.angle = 0.0  # rad, the last estimate's
        self.last: ArmReading | None = None  # the last pose reading
        self.reading = False  # the last frame had a reading (pose or DON)
        self.don: DON | None = None
        self.origin = np.zeros(2)  # the crop's top-left corner, input px
        self.side = 0.0  # the crop's side, input px
        self.seed_direction = 0.0  # DON's reference direction: the upper arm at seeding
        self.forearm = 0.0  # forearm length at seeding, input px
        self.pose_frames = 0  # frames the pose model read (speed bookkeeping)
        # What gave the last estimate: "pose" (a pose frame), "don" (DON's turn), "rolled"
        # (rolled on at the pose rate) or "none" (nobody in view: held, trust 0).
        self.source = "none"
        # (angle, DON's forearm direction) on the frame DON's turns are counted from
        self.anchor: tuple[float, float] | None = None
        self.rate = 0.0  # rad a frame: the turn between the last two pose frames
        self.at_pose = 0.0  # rad: the estimate on the last pose frame
        self.jump: float | None = None  # rad a frame: the last pose frame's jump, if it was one
        self.carried = False  # DON turned the estimate since the last pose frame

    # Seeding ------------------------------------------------------------------------
    def _seed(self, frame: np.ndarray, reading: ArmReading) -> None:
        """A fresh DON on a crop centred on the reading's elbow, with that elbow as its
        pivot and the upper arm as its reference direction."""
        shoulder, elbow, wrist = reading.keypoints
        self.forearm = max(float(np.hypot(*(wrist - elbow))), 1.0)
        self.side = max(REACH * self.forearm, MIN_SIDE)
        self.origin = elbow - self.side / 2
        self.seed_direction = _direction(shoulder, elbow)
        self.don = DON(fps=self.fps, window=self.window, pivot=(CROP / 2, CROP / 2),
                       reference_direction=self.seed_direction, joint_range=ELBOW_RANGE)
        self.don.update(self._crop(frame))

    def _crop(self, frame: np.ndarray) -> np.ndarray:
        """The (CROP, CROP, 3) uint8 square about the seeded elbow (outside the frame:
        its edge pixels repeated)."""
        scale = CROP / self.side
        warp = np.array([[scale, 0.0, -self.origin[0] * scale],
                         [0.0, scale, -self.origin[1] * scale]])
        return cv2.warpAffine(frame, warp, (CROP, CROP), flags=cv2.INTER_AREA,
                              borderMode=cv2.BORDER_REPLICATE)

    def _moved(self, reading: ArmReading) -> bool:
        """The person moved enough that the crop no longer fits the arm."""
        _, elbow, wrist = reading.keypoints
        shift = float(np.hypot(*(elbow - (self.origin + self.side / 2))))
        length = float(np.hypot(*(wrist - elbow)))
        return shift > MOVE * self.forearm or abs(length / self.forearm - 1.0) > SCALE

    # Frames -------------------------------------------------------------------------
    def update(self, frame: np.ndarray) -> Estimate:
        """Take the next (H, W, 3) uint8 RGB frame and return the estimate for it."""
        self.frame += 1
        self.since_pose += 1
        don = self.don.update(self._crop(frame)) if self.don is not None else None
        direction = self._don_direction(don)
        if self.reading and self.last is not None and self.since_pose < self.pose_every:
            angle, turned = self._carried(direction)
            self.source = "don" if turned else "rolled"
            self.carried = self.carried or turned
            return self._estimate(angle, self.last.trust, self._drawn(angle))
        previous = (replace(self.last, angles=np.array([self.angle]))
                    if self.reading and self.last is not None else None)
        reading = self.pose.read(frame, previous, (self.frame - 1) / self.fps)
        since, self.since_pose = self.since_pose, 0
        self.pose_frames += 1
        self.source = "pose" if reading is not None else "none"
        if reading is None:
            self.don, self.last, self.anchor, self.jump = None, None, None, None
            self.rate = 0.0
            return self._hold()
        angle = float(reading.angles[0])
        same_arm = previous is not None and reading.side == previous.side
        reseed = self.don is None or not same_arm or self._moved(reading)
        if same_arm:
            assert self.last is not None
            raw_rate = float(wrap_angle(angle - self.last.angles[0])) / since
            predicted, turned = self._carried(direction)
            surprise = float(wrap_angle(angle - predicted))
            if abs(surprise) > DISAGREE:  # not jitter: the arm is where the model sees it
                reseed = reseed or self.carried or turned  # DON's turns led elsewhere
                # One jump is a new place, not a speed; two alike in a row are a speed.
                self.rate = raw_rate if _alike(raw_rate, self.jump) else 0.0
                self.jump = raw_rate
                self.path.reset()  # no velocity from the jump
            else:  # the model's reading weighed against the carried estimate
                angle = continue_within(predicted + GAIN * surprise, ELBOW_RANGE, self.angle)
                self.rate = float(wrap_angle(angle - self.at_pose)) / since
                self.jump = None
        else:  # the first reading, or the other arm: nothing to carry on from
            self.rate, self.jump = 0.0, None
            self.path.reset()
        if reseed:
            self._seed(frame, reading)
            direction = None
        else:  # the same crop: DON's pivot follows the elbow the pose model sees
            assert self.don is not None
            self.don.move_pivot(tuple((reading.keypoints[1] - self.origin) * CROP / self.side))
        self.last, self.carried, self.at_pose = reading, False, angle
        self.anchor = None if direction is None else (angle, direction)
        return self._estimate(angle, reading.trust, self._drawn(angle))

    def _don_direction(self, don: Estimate | None) -> float | None:
        """DON's image direction of the forearm this frame (rad), else None: no DON, or no
        reading of this frame (layer 5's prediction, or the last reading held because
        neither the motion layers nor the appearance layer saw the link)."""
        if (don is None or self.don is None or don.keypoints is None or don.predicted
                or not (self.don.read or self.don.appearance_read)):
            return None
        return float(wrap_angle(self.seed_direction + float(don.angles[0])))

    def _carried(self, direction: float | None) -> tuple[float, bool]:
        """This frame's angle carried on from the last estimate, and whether DON's reading
        (its forearm ``direction``, None: no reading) turned it. Where DON reads the
        forearm: the angle at its anchor (the pose frame, or the first frame since on
        which DON read) turned as far as DON saw the forearm turn since. Else the last
        estimate rolled on at the turn rate between the last two pose frames."""
        if direction is not None:
            anchor = self.anchor if self.anchor is not None else (self.angle + self.rate,
                                                                  direction)
            angle = continue_within(anchor[0] + float(wrap_angle(direction - anchor[1])),
                                    ELBOW_RANGE, self.angle)
            if abs(float(wrap_angle(angle - self.angle))) <= MAX_STEP:
                self.anchor = anchor
                return angle, True
            self.anchor = None  # DON jumped: not the forearm
        return continue_within(self.angle + self.rate, ELBOW_RANGE, self.angle), False

    def _drawn(self, angle: float) -> np.ndarray:
        """The forearm drawn at ``angle``: the last pose frame's elbow and wrist (2, 2) px,
        the wrist turned about the elbow from that frame's reading to ``angle``."""
        assert self.last is not None
        elbow, wrist = self.last.keypoints[1:]
        turn = angle - float(self.last.angles[0])
        c, s = math.cos(turn), math.sin(turn)
        dx, dy = wrist - elbow
        return np.array([elbow, elbow + np.array([c * dx + s * dy, -s * dx + c * dy])])

    def _estimate(self, angle: float, trust: float, keypoints: np.ndarray) -> Estimate:
        if not self.reading:
            self.path.reset()  # seen again: no velocity from the gap
        self.angle, self.reading = angle, True
        self.path.update((angle,))
        angles, omega, alpha = np.array([angle]), self.path.omega(), self.path.alpha()
        torque = (self.torque_model(angles, omega, alpha) if self.torque_model is not None
                  else np.zeros(1))
        return Estimate(angles=angles, omega=omega, alpha=alpha, torque=torque,
                        trust=min(max(trust, 0.0), 1.0), keypoints=keypoints)

    def _hold(self) -> Estimate:
        self.reading = False
        zeros = np.zeros(1)
        return Estimate(angles=np.array([self.angle]), omega=zeros, alpha=zeros,
                        torque=zeros, trust=0.0)

    def run(self, frames) -> list[Estimate]:
        """Estimates for every frame of an iterable (a clip's frames, a video reader)."""
        self.reset()
        return [self.update(frame) for frame in frames]
