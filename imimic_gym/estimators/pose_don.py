"""Pose-seeded DON (registry name ``pose-don``): the pose model places DON on the forearm,
DON carries the forearm between pose frames.

The pose model (`pose.PoseEstimator.read`) costs some 17 ms a frame on 2 CPU cores; DON
well under one on a small crop. So the pose model reads every ``pose_every``-th frame and
hands DON what the paper's DON has to find by itself: its pivot (the elbow), its
reference direction (the upper arm) and its working area, a square crop about the elbow
of ``REACH`` forearm lengths a side, resized to ``CROP`` px (in a 1920x1080 frame a
forearm is a few pixels of a whole frame at DON's 120 rows; on the crop it is half its
height). DON runs on that crop every frame; between pose frames its reading, taken from
the upper arm the pose model last saw, is the estimate.

The pose model reads the frame instead when DON has no trusted reading (it needs
``window`` frames of motion after a seed, paper layer 1). On each pose frame DON's pivot
moves to the elbow the pose model sees (`DON.move_pivot`), keeping DON's frames. DON is
seeded afresh on a pose frame when it has had twice its window and still has no trusted
reading, when the elbow has moved off the crop's centre by over ``MOVE`` forearm
lengths or the
forearm's length has changed by over ``SCALE`` (the person moved), or when DON and the
pose model disagree by over ``DISAGREE`` on a pose frame. Between pose frames a DON
reading that turns the forearm by over ``MAX_STEP`` in a frame is not taken either: the
pose model reads that frame. Nobody in view: trust 0, the
angle held, as `PoseEstimator`.
"""

from __future__ import annotations

import math

import cv2
import mujoco
import numpy as np

from imimic_gym.estimators.don import DON
from imimic_gym.estimators.motion import PathEstimator, TorqueModel
from imimic_gym.estimators.pose import ELBOW_RANGE, ArmReading, PoseEstimator, continue_within
from imimic_gym.estimators.pose_model import PoseModel
from imimic_gym.estimators.types import Estimate
from imimic_gym.kinematics import wrap_angle

__all__ = ["CROP", "PoseSeededDON"]

CROP = 120  # px a side of the crop DON reads: its working height, so no further scaling
REACH = 3.2  # the crop's side in forearm lengths: the forearm fits whichever way it points
MIN_SIDE = 32.0  # input px: the smallest crop
MOVE = 0.5  # elbow shift off the crop's centre, in forearm lengths, that re-seeds DON
SCALE = 0.5  # relative change of the forearm's length that re-seeds DON
DISAGREE = math.radians(20.0)  # DON against the pose model on a pose frame: re-seed
TRUST_FLOOR = 0.5  # DON's eta below this: the pose model reads the frame
# DON's reading that turns the forearm further than this from the last frame's estimate
# is not taken: the pose model reads the frame (an elbow at 450 deg/s turns 15 deg a
# frame at 30 fps).
MAX_STEP = math.radians(15.0)


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
        pose_every: the pose model reads at least every this many frames.
        window: DON's window N (frames).
        robot: the robot's MuJoCo model, for torques; None gives zero torque.
        model: a `PoseModel` to use (None: a new one, in video mode).
    """

    def __init__(self, fps: float = 30.0, reference_direction: float = -math.pi / 2,
                 arm: str = "auto", min_confidence: float = 0.5, pose_every: int = 3,
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
        self.seeded_at = 0  # the frame DON was last seeded on
        self.origin = np.zeros(2)  # the crop's top-left corner, input px
        self.side = 0.0  # the crop's side, input px
        self.seed_direction = 0.0  # DON's reference direction: the upper arm at seeding
        self.forearm = 0.0  # forearm length at seeding, input px
        self.pose_frames = 0  # frames the pose model read (speed bookkeeping)

    # Seeding ------------------------------------------------------------------------
    def _seed(self, frame: np.ndarray, reading: ArmReading) -> None:
        """A fresh DON on a crop centred on the reading's elbow, with that elbow as its
        pivot and the upper arm as its reference direction."""
        shoulder, elbow, wrist = reading.keypoints
        self.forearm = max(float(np.hypot(*(wrist - elbow))), 1.0)
        self.side = max(REACH * self.forearm, MIN_SIDE)
        self.origin = elbow - self.side / 2
        self.seed_direction = _direction(shoulder, elbow)
        self.seeded_at = self.frame
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
        trusted = (don is not None and float(don.trust) >= TRUST_FLOOR
                   and don.keypoints is not None)
        if (trusted and don is not None and self.last is not None
                and self.since_pose < self.pose_every):
            angle = self._don_angle(don, self.last)
            if self.reading and abs(float(wrap_angle(angle - self.angle))) <= MAX_STEP:
                return self._from_don(don, angle)
        previous = np.array([self.angle]) if self.reading else None
        reading = self.pose.read(frame, previous)
        self.since_pose = 0
        self.pose_frames += 1
        if reading is None:
            self.don, self.last = None, None
            return self._hold()
        settled = self.frame - self.seeded_at > 2 * int(self.window)  # DON had its chance
        if (self.don is None or self._moved(reading) or (settled and not trusted)
                or (trusted and abs(float(wrap_angle(self._don_angle(don, reading)
                                                     - reading.angles[0]))) > DISAGREE)):
            self._seed(frame, reading)
        else:  # the same crop: DON's pivot follows the elbow the pose model sees
            self.don.move_pivot(tuple((reading.keypoints[1] - self.origin) * CROP / self.side))
        self.last = reading
        return self._estimate(float(reading.angles[0]), reading.trust,
                              reading.keypoints[1:])

    def _don_angle(self, don: Estimate | None, reading: ArmReading) -> float:
        """DON's forearm direction as an angle from ``reading``'s upper arm (rad)."""
        if don is None:
            return math.inf
        shoulder, elbow, _ = reading.keypoints
        return float(wrap_angle(self.seed_direction + float(don.angles[0])
                                - _direction(shoulder, elbow)))

    def _from_don(self, don: Estimate, angle: float) -> Estimate:
        """The estimate from DON's reading of this frame, ``angle`` about the last pose
        frame's upper arm."""
        assert don.keypoints is not None
        angle = continue_within(angle, ELBOW_RANGE, self.angle)
        keypoints = self.origin + don.keypoints * (self.side / CROP)
        return self._estimate(angle, don.trust, keypoints)

    def _estimate(self, angle: float, trust: float, keypoints: np.ndarray) -> Estimate:
        if not self.reading:
            self.path.reset()  # seen again: no velocity from the gap
        self.angle, self.reading = angle, True
        self.path.update((angle,))
        angles, omega, alpha = np.array([angle]), self.path.omega(), self.path.alpha()
        torque = (self.torque_model(angles, omega, alpha) if self.torque_model is not None
                  else np.zeros(1))
        return Estimate(angles=angles, omega=omega, alpha=alpha, torque=torque,
                        trust=min(max(trust, 0.0), 1.0), keypoints=np.asarray(keypoints))

    def _hold(self) -> Estimate:
        self.reading = False
        zeros = np.zeros(1)
        return Estimate(angles=np.array([self.angle]), omega=zeros, alpha=zeros,
                        torque=zeros, trust=0.0)

    def run(self, frames) -> list[Estimate]:
        """Estimates for every frame of an iterable (a clip's frames, a video reader)."""
        self.reset()
        return [self.update(frame) for frame in frames]
