"""The pose estimator (registry name ``pose``): a pretrained human-pose model finds a
person's shoulder, elbow and wrist in every frame, and they become joint angles by the
project's convention (`kinematics.keypoints_to_angles`: one link, the forearm
from the upper arm; two, the upper arm from the reference direction and the forearm
from it), then angular velocity, acceleration and torque through the shared path
estimator (paper layer 4a, `motion.PathEstimator`).

Which arm: the person's arm that moves (`ArmChooser`), or the one asked for. A human
elbow bends through about 150 degrees; seen in 2-D it bends either way, depending on
which side of the arm faces the camera, so the estimate keeps the forearm within
`ELBOW_RANGE` of the upper arm's line on both sides, continuing from frame to frame
(a fold seen past 180 degrees stays at its limit, not on the other side). A frame
without a person (or with the arm below ``min_confidence``) gives trust 0 and the last
angles, at rest: the robot holds.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

import mujoco
import numpy as np

from imimic_gym.estimators.joint_range import within_range
from imimic_gym.estimators.motion import PathEstimator, TorqueModel
from imimic_gym.estimators.pose.model import BodyKeypoints, PoseModel
from imimic_gym.estimators.types import Estimate
from imimic_gym.kinematics import keypoints_to_angles, wrap_angle

__all__ = ["ELBOW_RANGE", "FOLD_NOISE", "SHOULDER_RANGE", "ArmChooser", "ArmReading",
           "PoseEstimator", "continue_within", "human_joint_ranges"]

# Elbow flexion is 0 to about 150 degrees; a 2-D view shows it either way round, and the
# margin takes the model's noise and the projection of a straight arm.
ELBOW_RANGE = (-math.radians(175), math.radians(175))
# A turn past an elbow limit by more than this is the arm on the other side of the fold,
# not the model's noise at it (`continue_within`).
FOLD_NOISE = math.radians(45)
# The upper arm from the torso's axis: anywhere but straight up through the body.
SHOULDER_RANGE = (-math.radians(175), math.radians(175))


def human_joint_ranges(n_links: int) -> tuple[tuple[float, float], ...]:
    """Joint ranges (rad) of a human arm of ``n_links`` (1: the elbow; 2: shoulder and
    elbow) in the project's convention, for the robot that copies it."""
    if n_links == 1:
        return (ELBOW_RANGE,)
    if n_links == 2:
        return (SHOULDER_RANGE, ELBOW_RANGE)
    raise ValueError(f"a human arm is followed with 1 or 2 links, got {n_links}")


def continue_within(q: float, joint_range: tuple[float, float],
                    previous: float | None) -> float:
    """The reading ``q`` (rad) kept within ``joint_range``, continuing ``previous`` (the
    frame before's angle; None: nothing to continue). A folded elbow seen in 2-D reads
    near +-180 degrees and its noise crosses that line, which is no reason for the robot
    to swing the long way round; so the reading is taken as the turn from the previous
    angle (within +-180 degrees of it) and stopped at the limit it passes. A turn that
    would pass the limit by over ``FOLD_NOISE`` is no noise at the fold: the elbow cannot
    pass through it, so the arm went the other way round, and the reading stands as the
    angle within the range (an arm first read folded on the far side, then unfolding)."""
    low, high = joint_range
    if previous is None:
        return within_range(q, joint_range)
    turned = previous + float(wrap_angle(q - previous))
    past = max(turned - high, low - turned)
    if past > FOLD_NOISE:
        other = turned - 2 * math.pi if turned > high else turned + 2 * math.pi
        if low <= other <= high:
            return other
    return min(max(turned, low), high)


@dataclass(frozen=True)
class ArmReading:
    """One frame's arm from the pose model.

    Attributes:
        side: "left" or "right", the person's own.
        keypoints: (3, 2) float64 input pixels (x, y) of shoulder, elbow, wrist.
        confidence: (3,) float64 in [0, 1], one per keypoint.
        angles: (n,) rad, the project's convention, within the human ranges.
    """

    side: str
    keypoints: np.ndarray
    confidence: np.ndarray
    angles: np.ndarray

    @property
    def trust(self) -> float:
        return float(self.confidence.min())


class ArmChooser:
    """Which of a person's arms to follow: ``arm`` if it is "left" or "right", else the
    one that moves.

    Motion is the forearm's image direction change (rad) between consecutive readings in
    which both its elbow and wrist are confident, summed over the last ``window_s``
    seconds of the video (however many frames were read in them). It starts with an arm
    that can be read (shoulder, elbow and wrist at ``min_confidence`` or more; of two, or
    of none, the more confident forearm; ties: right), and until the arm it holds has
    been read once, it takes a readable arm over an unreadable one each frame: an arm
    that was never seen does not keep the choice from one that is. After that the other
    arm takes over once it has moved ``ratio`` times as much and at least ``min_motion``
    rad in the window, so a still arm's jitter never steals the choice from the moving
    one.
    """

    def __init__(self, fps: float, arm: str = "auto", window_s: float = 1.0,
                 ratio: float = 2.0, min_motion: float = 0.3,
                 min_confidence: float = 0.5) -> None:
        if arm not in ("auto", "left", "right"):
            raise ValueError(f"arm must be 'auto', 'left' or 'right', got {arm!r}")
        self.arm, self.ratio, self.min_motion = arm, ratio, min_motion
        self.min_confidence, self.fps = min_confidence, float(fps)
        # Readings older than this many seconds leave the window (one frame's less than
        # window_s, as a window of round(window_s * fps) frames).
        self.window_s = (max(2, round(window_s * fps)) - 0.5) / fps
        self.reset()

    def reset(self) -> None:
        self.side: str | None = None if self.arm == "auto" else self.arm
        self.motion: dict[str, deque[tuple[float, float]]] = {
            side: deque() for side in ("left", "right")}  # (time s, turn rad)
        self.direction: dict[str, float | None] = {"left": None, "right": None}
        self.read = {"left": False, "right": False}  # read once (all three confident)?
        self.calls = 0

    def __call__(self, body: BodyKeypoints, time_s: float | None = None) -> str:
        """The side to follow in this reading (call once per reading, in order;
        ``time_s``: its time in the video, None: one frame after the last)."""
        now = self.calls / self.fps if time_s is None else float(time_s)
        if not math.isfinite(now):
            raise ValueError(f"ArmChooser: time_s must be a finite number of seconds, "
                             f"got {time_s!r}")
        self.calls += 1
        confident: dict[str, np.ndarray] = {}  # each arm's (3,) keypoint confidences
        for side in ("left", "right"):
            points, confidence = body.arm(side)
            confident[side] = confidence
            motion = self.motion[side]
            while motion and motion[0][0] <= now - self.window_s:
                motion.popleft()
            if min(confidence[1], confidence[2]) < self.min_confidence:
                self.direction[side] = None
                continue
            dx, dy = points[2] - points[1]
            direction = math.atan2(-dy, dx)
            last = self.direction[side]
            if last is not None:
                motion.append((now, abs(float(wrap_angle(direction - last)))))
            self.direction[side] = direction
        if self.arm != "auto":
            return self.arm
        moved = {side: sum(turn for _, turn in values) for side, values in self.motion.items()}
        readable = {side: float(c.min()) >= self.min_confidence
                    for side, c in confident.items()}
        if self.side is None or not self.read[self.side]:  # never read: a readable arm
            self.side = max(moved, key=lambda side: (readable[side],
                                                     float(confident[side][1:].min()),
                                                     side == "right"))
        for side, now_readable in readable.items():
            self.read[side] = self.read[side] or now_readable
        other = "left" if self.side == "right" else "right"
        if moved[other] > max(self.ratio * moved[self.side], self.min_motion):
            self.side = other
        return self.side


class PoseEstimator:
    """A person's arm from a pretrained pose model, behind the `Estimator` interface.

    Args:
        n_links: 1 (the forearm about the elbow) or 2 (shoulder and elbow).
        fps: frame rate, for rad/s.
        reference_direction: image direction (rad, CCW from image right) of the torso's
            axis, for the 2-link shoulder angle.
        arm: "auto" (the arm that moves, `ArmChooser`), "left" or "right".
        min_confidence: a reading whose shoulder, elbow or wrist is less confident than
            this is not used (trust 0, the angles held).
        robot: the robot's MuJoCo model, for torques; None gives zero torque.
        model: a `PoseModel` to use (None: a new one, in video mode).
    """

    def __init__(self, n_links: int = 1, fps: float = 30.0,
                 reference_direction: float = -math.pi / 2, arm: str = "auto",
                 min_confidence: float = 0.5, robot: mujoco.MjModel | None = None,
                 model: PoseModel | None = None) -> None:
        if n_links not in (1, 2):
            raise ValueError(f"the pose estimator follows 1 or 2 links, got n_links={n_links}")
        if not (math.isfinite(fps) and fps > 0):
            raise ValueError(f"fps must be a positive number, got {fps!r}")
        if not 0.0 <= min_confidence <= 1.0:
            raise ValueError(f"min_confidence must be in [0, 1], got {min_confidence!r}")
        self.n_links, self.fps = n_links, float(fps)
        self.reference_direction, self.min_confidence = reference_direction, min_confidence
        self.ranges = human_joint_ranges(n_links)
        self.chooser = ArmChooser(fps, arm, min_confidence=min_confidence)
        self.model = model if model is not None else PoseModel(video=True)
        self.torque_model = TorqueModel(robot) if robot is not None else None
        self.reset()

    def reset(self) -> None:
        self.model.reset()
        self.chooser.reset()
        self.path = PathEstimator(self.n_links, self.fps)
        self.angles = np.zeros(self.n_links)
        self.last: ArmReading | None = None
        self.reads = 0  # frames read since reset

    def prefetch(self, frame: np.ndarray) -> None:
        """Start the pose model on ``frame``, the frame after those given to `update` (or
        here) so far, on the model's thread (`PoseModel.submit`), while the caller works;
        ``update`` of that same array then takes its reading. For frames read one after
        another (no ``time_s`` given to `read`)."""
        self.model.submit(frame, (self.reads + self.model.pending) / self.fps)

    def warm_up(self) -> None:
        """The pose model's first reading done now, on a blank frame (`PoseModel.warm_up`):
        the first frame then reads at full speed; the readings are unchanged."""
        self.model.warm_up()

    def close(self) -> None:
        """Stop the pose model (`PoseModel.close`); a later frame starts it again."""
        self.model.close()

    def read(self, frame: np.ndarray, previous: ArmReading | None = None,
             time_s: float | None = None) -> ArmReading | None:
        """This frame's arm, or None where no person (or no confident arm) is seen.
        ``previous``: the frame before's reading, if it had one (its angles may be
        replaced by an estimate's): a reading of the same arm continues from its angles
        (`continue_within`); the other arm starts afresh. ``time_s``: the frame's time in
        the video (s; None: one frame after the last read), for the model's filters and
        the arm chooser, so a caller that reads some frames only passes it."""
        if time_s is None:
            time_s = self.reads / self.fps
        self.reads += 1
        body = self.model(frame, time_s)
        if body is None:
            return None
        side = self.chooser(body, time_s)
        keypoints, confidence = body.arm(side)
        if confidence.min() < self.min_confidence:
            return None
        angles = keypoints_to_angles(keypoints, self.n_links, self.reference_direction)
        if previous is not None and previous.side != side:
            previous = None  # the other arm: nothing to continue
        angles = np.array([continue_within(float(q), joint_range,
                                           None if previous is None
                                           else float(previous.angles[j]))
                           for j, (q, joint_range) in enumerate(zip(angles, self.ranges,
                                                                    strict=True))])
        return ArmReading(side, keypoints, confidence, angles)

    def update(self, frame: np.ndarray) -> Estimate:
        """Take the next (H, W, 3) uint8 RGB frame and return the estimate for it."""
        return self.estimate(self.read(frame, self.last))

    def estimate(self, reading: ArmReading | None) -> Estimate:
        """The `Estimate` for a frame's reading (None: hold, trust 0)."""
        zeros = np.zeros(self.n_links)
        if reading is None:
            # Nothing seen: hold the last angles at rest. The path starts afresh at the
            # next reading, so a person who comes back is no velocity spike.
            self.path.reset()
            self.last = None
            return Estimate(angles=self.angles, omega=zeros, alpha=zeros, torque=zeros,
                            trust=0.0)
        if self.last is not None and reading.side != self.last.side:
            self.path.reset()  # the other arm: a jump, not a velocity
        self.last, self.angles = reading, reading.angles
        self.path.update(reading.angles)
        omega, alpha = self.path.omega(), self.path.alpha()
        torque = (self.torque_model(reading.angles, omega, alpha)
                  if self.torque_model is not None else zeros)
        shown = reading.keypoints[1:] if self.n_links == 1 else reading.keypoints
        return Estimate(angles=reading.angles, omega=omega, alpha=alpha, torque=torque,
                        trust=reading.trust, keypoints=shown)

    def run(self, frames) -> list[Estimate]:
        """Estimates for every frame of an iterable (a clip's frames, a video reader)."""
        self.reset()
        return [self.update(frame) for frame in frames]
