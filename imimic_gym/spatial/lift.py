"""Lifts: a pose model's 2-D keypoints of one arm to an `ArmPose` in the camera frame.

- `lift_arm` (one frame) and `ArmLifter` (a clip): the bone-length lift (Taylor's method,
  in perspective). The shoulder sits on its pixel's ray at the depth where the shoulders'
  2-D distance (or, if shorter in depth, the torso's) matches a person's width; each bone's
  far end sits on its pixel's ray at the bone's length from its start: a quadratic in the
  depth whose two roots are the bone turned toward or away from the camera. In
  `lift_arm` the pose model's depth order picks the root, and where it barely tells them
  apart, continuity with the previous frame does. `ArmLifter` instead keeps a Bayes
  filter per arm bone on its signed share between the roots
  (`spatial.share_filter.ShareFilter`: the bone's 2-D length and the model's depth as
  noisy readings) and takes its posterior mean scaled by the sign's certainty. A
  ray that misses the sphere (the 2-D bone is longer than the length allows) takes its
  point nearest the bone's start: the bone lies in the image plane and the length was
  too short, which `BoneLengthEstimator` learns from.
- `from_depth`: keypoints back-projected through a metric depth image (an RGB-D camera).
- `from_world_landmarks`: the pose model's own 3-D landmarks, moved into the camera frame
  (the baseline).

Input pixels and confidences are in `ARM_POINTS` order (shoulder, elbow, wrist, hand,
other shoulder, hip, other hip): (7, 2) float pixels (x, y) and (7,) in [0, 1]. The
model's relative depths (7,) are in pixels (MediaPipe's ``landmark.z`` times the image
width): smaller = nearer the camera; only their differences matter. How the priors and
settings were chosen: `docs/decisions/pose3d-lift.md`.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, replace

import numpy as np

from imimic_gym.spatial.arm_pose import ARM_POINTS, ArmPose, angle_between, unit
from imimic_gym.spatial.camera import Intrinsics
from imimic_gym.spatial.share_filter import (
    SHARE_FILTER,
    ShareFilter,
    expected_flexion,
    output_share,
    predict_belief,
    uniform_belief,
    weigh_readings,
)
from imimic_gym.spatial.smoothing import OneEuroFilter, OneEuroSettings

__all__ = ["DEFAULT_DEPTH", "FLIP_PATIENCE", "KEYPOINT_NOISE", "LENGTH_QUANTILE", "LIMB_RADIUS",
           "MAX_TURN_RATE", "ONE_EURO", "SIGN_MARGIN", "SIGN_THRESHOLD", "ArmLifter",
           "BoneLengthEstimator", "BoneLengths", "from_depth", "from_world_landmarks",
           "lift_arm", "neutral_pose", "out_of_plane", "shoulder_depth"]

_S, _E, _W, _H, _OS, _HIP, _OHIP = range(len(ARM_POINTS))
# Where the shoulders' depth cannot be told (shoulders on one pixel): a person at arm's
# length plus a bit from a webcam, metres.
DEFAULT_DEPTH = 2.5
_DEPTH_RANGE = (0.2, 50.0)  # metres: a shoulder depth is kept within this
# Where the model's depth of a bone's far end lies within this share of the two roots'
# half gap of their middle, its depth order does not pick the root; continuity with the
# previous frame does; so too within `SIGN_MARGIN` metres (the model's own depth noise).
SIGN_THRESHOLD = 0.25
SIGN_MARGIN = 0.0
# The lift's smoothing of the 3-D points (`ArmLifter`).
ONE_EURO = OneEuroSettings(min_cutoff=5.0, beta=5.0)
# The pose model's noise on an arm bone's 2-D length, as a share of the length
# (`out_of_plane`; `ArmLifter`'s).
KEYPOINT_NOISE = 0.04
# An arm bone turns at most this fast (rad/s; `ArmLifter`): a turn the model's depth
# order would make faster is its depth flipping, for as long as `FLIP_PATIENCE` (s).
MAX_TURN_RATE = math.radians(900.0)
FLIP_PATIENCE = 0.3
# The turn limit holds a bone whose depth extent was over this share of its length: one
# near the image plane may take either root (the model's noise there is no flip).
_LOCKED_SHARE = 0.5
# `BoneLengthEstimator`'s quantile of the in-plane bounds.
LENGTH_QUANTILE = 0.8
# A shoulder this far (metres) behind the elbow's, other shoulder's and hips' median
# depth is the wall behind it (`from_depth`).
_BEHIND = 0.3
# A shoulder this far (metres) in front of both its own hip and the other shoulder (each
# seen with confidence 0.5 or more) has something before it, a hand raised to it
# (`from_depth`): a torso turned puts its hip level with it, one leaning the other
# shoulder.
_IN_FRONT = 0.15
# Limb radii (metres): a depth camera sees a limb's surface, this far in front of its axis.
LIMB_RADIUS = np.array([0.05, 0.04, 0.03, 0.015, 0.05, 0.08, 0.08])
_HIP_WIDTH_RATIO = 0.7  # the hips' keypoints' distance / the shoulders'
# The arm's bones, lifted in this order: (start, end, the `BoneLengths` field).
_ARM_BONES = ((_S, _E, "upper_arm"), (_E, _W, "forearm"), (_W, _H, "hand"))


@dataclass(frozen=True)
class BoneLengths:
    """One person's lengths, metres, between the pose model's keypoints.

    Attributes:
        shoulder_width: between the two shoulder keypoints (the scale's anchor).
        torso: the shoulders' middle to the hips' middle.
        upper_arm: shoulder to elbow. forearm: elbow to wrist. hand: wrist to the index
            finger's knuckle.
    """

    shoulder_width: float = 0.36
    torso: float = 0.50
    upper_arm: float = 0.29
    forearm: float = 0.25
    hand: float = 0.09

    def __post_init__(self) -> None:
        for name in ("shoulder_width", "torso", "upper_arm", "forearm", "hand"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0):
                raise ValueError(f"BoneLengths.{name} must be a length in metres (>= 0), "
                                 f"got {value!r}")

    @classmethod
    def from_shoulder_width(cls, width: float) -> BoneLengths:
        """An average adult's proportions (the defaults) scaled to ``width`` metres."""
        average = cls()
        return cls(**{name: value * width / average.shoulder_width
                      for name, value in _as_dict(average).items()})

    @property
    def arm(self) -> np.ndarray:
        """(3,) metres: upper arm, forearm, hand."""
        return np.array([self.upper_arm, self.forearm, self.hand])


def _as_dict(lengths: BoneLengths) -> dict[str, float]:
    return {name: getattr(lengths, name)
            for name in ("shoulder_width", "torso", "upper_arm", "forearm", "hand")}


def _check_inputs(side: str, pixels: np.ndarray, confidence: np.ndarray
                  ) -> tuple[np.ndarray, np.ndarray]:
    k = len(ARM_POINTS)
    pixels = np.asarray(pixels, dtype=np.float64)
    confidence = np.asarray(confidence, dtype=np.float64)
    if pixels.shape != (k, 2) or confidence.shape != (k,):
        raise ValueError(f"a lift needs pixels ({k}, 2) and confidence ({k},), got "
                         f"{pixels.shape} and {confidence.shape}")
    if not (np.isfinite(pixels).all() and np.isfinite(confidence).all()):
        raise ValueError("a lift needs finite pixels and confidences")
    if side not in ("left", "right"):
        raise ValueError(f"side must be 'left' or 'right', got {side!r}")
    return pixels, np.clip(confidence, 0.0, 1.0)


def shoulder_depth(pixels: np.ndarray, confidence: np.ndarray, intrinsics: Intrinsics,
                   lengths: BoneLengths, min_confidence: float = 0.5) -> float:
    """The shoulder's depth (z, metres, camera frame) at which the shoulders' 2-D distance
    is ``lengths.shoulder_width`` or, with both hips seen (``min_confidence``), the
    torso's 2-D length is ``lengths.torso``, whichever is nearer: a segment turned in depth
    looks shorter and so reads farther, never nearer. Exact for shoulders (or a torso)
    square to the camera's axis. `DEFAULT_DEPTH` where neither can be told."""
    rays = intrinsics.rays(pixels)
    candidates = []
    width = float(np.linalg.norm(rays[_S] - rays[_OS]))
    if width > 1e-9 and lengths.shoulder_width > 0:
        candidates.append(lengths.shoulder_width / width)
    if min(confidence[_HIP], confidence[_OHIP]) >= min_confidence and lengths.torso > 0:
        torso = float(np.linalg.norm(0.5 * (rays[_S] + rays[_OS])
                                     - 0.5 * (rays[_HIP] + rays[_OHIP])))
        if torso > 1e-9:
            candidates.append(lengths.torso / torso)
    depth = min(candidates) if candidates else DEFAULT_DEPTH
    return float(np.clip(depth, *_DEPTH_RANGE))


@dataclass(frozen=True)
class _Bone:
    """A bone's far end as solved: the point, the in-plane lower bound on its length
    (metres: the distance from its start to the far end's ray), whether the ray missed
    the length's sphere, and whether the turn limit overruled the model's depth order."""

    end: np.ndarray
    lower_bound: float
    missed: bool
    overruled: bool = False


_OUT_OF_PLANE_GRID = np.linspace(0.0, 1.0, 201)


def out_of_plane(ratio: float, noise: float) -> float:
    """A bone's expected out-of-plane share (|its extent along the line of sight| / its
    length, in [0, 1)) given ``ratio``, its in-plane extent over its length as measured,
    when that ratio carries Gaussian noise of standard deviation ``noise`` and the bone
    points anywhere on the sphere (the share uniform in [0, 1]). With no noise, Taylor's
    sqrt(1 - ratio^2) (0 past 1). Noise makes a bone near the image plane measure
    sometimes longer, sometimes shorter than its length; the plain formula then turns
    every short reading into a tilt, so it over-tilts such bones, which this does not."""
    if noise <= 0.0:
        return math.sqrt(max(1.0 - ratio * ratio, 0.0))
    in_plane = np.sqrt(1.0 - _OUT_OF_PLANE_GRID ** 2)
    weights = np.exp(-0.5 * ((ratio - in_plane) / noise) ** 2)
    total = float(weights.sum())
    if not total > 0.0:  # far from any bone this long: the nearest reading's share
        return 0.0 if ratio > 1.0 else math.sqrt(max(1.0 - ratio * ratio, 0.0))
    return min(float(weights @ _OUT_OF_PLANE_GRID) / total, 0.999)


def _filter_bone(start: np.ndarray, ray: np.ndarray, length: float,
                 model_delta: float | None, belief: np.ndarray, settings: ShareFilter
                 ) -> tuple[_Bone, np.ndarray]:
    """The far end on ``ray`` at the bone's share (`ShareFilter`: the posterior mean
    times the sign's certainty), given the ``belief`` (on `SHARE_GRID`, predicted to
    this frame) and this frame's readings (``model_delta`` as `_solve_bone`'s), and the
    posterior."""
    a = float(ray @ ray)
    root_a = math.sqrt(a)
    middle = float(ray @ start) / a  # t of the ray's point nearest the start
    lower_bound = math.sqrt(max(float(start @ start) - a * middle * middle, 0.0))
    missed = lower_bound > length
    if not length > 0.0:
        return _Bone(max(middle, _DEPTH_RANGE[0]) * ray, lower_bound, missed), belief
    evidence = (None if model_delta is None
                else (start[2] + model_delta - middle) * root_a / length)
    posterior = weigh_readings(belief, lower_bound / length, evidence, settings)
    share = output_share(posterior, settings)
    t = max(middle + share * length / root_a, _DEPTH_RANGE[0])
    return _Bone(t * ray, lower_bound, missed), posterior


def _solve_bone(start: np.ndarray, ray: np.ndarray, length: float,
                model_delta: float | None, previous: np.ndarray | None,
                sign_threshold: float, noise: float = 0.0, sign_margin: float = 0.0,
                max_turn: float = math.inf) -> _Bone:
    """The point t * ``ray`` (t > 0) at ``length`` from ``start``. ``model_delta``: the
    pose model's depth of the far end minus the start's, metres (None: unknown);
    ``previous``: the bone's unit direction in the previous frame (None: none);
    ``noise``: the bone's in-plane ratio's noise (`out_of_plane`; 0: Taylor's exact
    solution, the far end at exactly ``length``); ``sign_threshold`` and ``sign_margin``:
    see `SIGN_THRESHOLD` and `SIGN_MARGIN`; ``max_turn``: rad, where ``previous`` points
    well out of the image plane (`_LOCKED_SHARE`), a root the model picks that turns the
    bone farther than this from it gives way to the other root if that one turns it
    less."""
    a = float(ray @ ray)
    middle = float(ray @ start) / a  # t of the ray's point nearest the start
    lower_bound = math.sqrt(max(float(start @ start) - a * middle * middle, 0.0))
    missed = lower_bound > length
    if noise > 0.0 and length > 0.0:
        share = out_of_plane(lower_bound / length, noise)
        # Along the ray, the extent that gives the bone this out-of-plane share.
        half_gap = lower_bound * share / math.sqrt(1.0 - share * share) / math.sqrt(a)
    else:
        disc = middle * middle - (float(start @ start) - length * length) / a
        half_gap = math.sqrt(disc) if disc > 0.0 else 0.0
    if half_gap <= 0.0:  # the bone lies in the image plane
        return _Bone(max(middle, _DEPTH_RANGE[0]) * ray, lower_bound, missed)
    near, far = middle - half_gap, middle + half_gap
    if near <= _DEPTH_RANGE[0]:  # the camera inside the sphere: only the far root is real
        return _Bone(far * ray, lower_bound, missed)
    roots = (near * ray, far * ray)
    # The model's depth of the far end against the two roots' middle (the bone in the
    # image plane): nearer is the root toward the camera, farther the one away.
    evidence = None if model_delta is None else start[2] + model_delta - middle
    unsure = evidence is None or abs(evidence) < max(sign_threshold * half_gap, sign_margin)
    if unsure and previous is not None:
        choice = max(range(2), key=lambda i: float(unit(roots[i] - start) @ previous))
        return _Bone(roots[choice], lower_bound, missed)
    choice = int(evidence is not None and evidence > 0.0)
    if previous is not None and math.isfinite(max_turn) and abs(previous[2]) > _LOCKED_SHARE:
        turns = [float(angle_between(root - start, previous)) for root in roots]
        if turns[choice] > max_turn and turns[1 - choice] < turns[choice]:
            return _Bone(roots[1 - choice], lower_bound, missed, overruled=True)
    return _Bone(roots[choice], lower_bound, missed)


def lift_arm(side: str, pixels: np.ndarray, confidence: np.ndarray,
             depth: np.ndarray | None, intrinsics: Intrinsics, lengths: BoneLengths,
             depth_of_shoulder: float | None = None, previous: ArmPose | None = None,
             sign_threshold: float = SIGN_THRESHOLD, sign_margin: float = 0.0,
             keypoint_noise: float = 0.0, max_turn: float = math.inf) -> ArmPose:
    """One frame's bone-length lift (module docstring).

    Args:
        side: "left" or "right", the person's own.
        pixels: (7, 2) pixels (x, y), `ARM_POINTS` order. confidence: (7,) in [0, 1].
        depth: (7,) the pose model's relative depths in pixels (smaller = nearer), for
            the toward/away choice; None: continuity alone (toward the camera at first).
        intrinsics: the camera's.
        lengths: the person's bone lengths, metres.
        depth_of_shoulder: the shoulder's z (metres); None: `shoulder_depth`.
        previous: the previous frame's pose of this arm, for continuity (None: none).
        sign_threshold: see `SIGN_THRESHOLD`.
        sign_margin: see `SIGN_MARGIN` (0: the model's order counts however small).
        keypoint_noise: the noise of an arm bone's measured in-plane length, as a share
            of its length (`out_of_plane`); 0: Taylor's exact solution (each far end at
            exactly its bone's length).
        max_turn: rad; where an arm bone pointed well out of the image plane in
            ``previous`` and the model's depth order would turn it farther than this
            from there while the other root turns it less, the other root (the model's
            depth flips for a few frames now and then, while an arm cannot swing
            through half a turn between two frames); inf: no limit.

    Returns:
        The `ArmPose` (camera frame), ``trust`` the least confidence of shoulder, elbow
        and wrist. Finite for any finite input.
    """
    return _lift(side, pixels, confidence, depth, intrinsics, lengths, depth_of_shoulder,
                 previous, sign_threshold, sign_margin, keypoint_noise,
                 np.full(len(_ARM_BONES), max_turn))[0]


def _lift(side: str, pixels: np.ndarray, confidence: np.ndarray, depth: np.ndarray | None,
          intrinsics: Intrinsics, lengths: BoneLengths, depth_of_shoulder: float | None,
          previous: ArmPose | None, sign_threshold: float, sign_margin: float,
          keypoint_noise: float, max_turn: np.ndarray,
          beliefs: list[np.ndarray] | None = None, share_filter: ShareFilter | None = None
          ) -> tuple[ArmPose, np.ndarray, np.ndarray]:
    """`lift_arm` (``max_turn`` one per arm bone), the (3,) in-plane lower bounds of the
    arm's bones (metres) and (3,) bool: which of them the turn limit overruled. Given
    ``share_filter`` and ``beliefs`` (one per arm bone, on `SHARE_GRID`, predicted to this
    frame), the arm's bones are solved by the filter instead (`ShareFilter`; the sign
    rules, ``keypoint_noise`` and ``max_turn`` unused) and ``beliefs`` is replaced in
    place by their posteriors."""
    pixels, confidence = _check_inputs(side, pixels, confidence)
    if depth is not None:
        depth = np.asarray(depth, dtype=np.float64)
        if depth.shape != (len(ARM_POINTS),) or not np.isfinite(depth).all():
            raise ValueError(f"a lift's model depths must be finite with shape "
                             f"({len(ARM_POINTS)},), got {depth.shape}")
    z0 = (shoulder_depth(pixels, confidence, intrinsics, lengths)
          if depth_of_shoulder is None else float(np.clip(depth_of_shoulder, *_DEPTH_RANGE)))
    rays = intrinsics.rays(pixels)
    metres_per_pixel = z0 / math.sqrt(intrinsics.fx * intrinsics.fy)
    points = np.zeros((len(ARM_POINTS), 3))
    points[_S] = z0 * rays[_S]

    def model_delta(start: int, end: int) -> float | None:
        return None if depth is None else float(depth[end] - depth[start]) * metres_per_pixel

    def previous_direction(start: int, end: int) -> np.ndarray | None:
        if previous is None or previous.side != side:
            return None
        direction = unit(previous.points[end] - previous.points[start])
        return direction if direction.any() else None

    def solve(start: int, end: int, length: float, noise: float = 0.0,
              turn: float = math.inf) -> _Bone:
        bone = _solve_bone(points[start], rays[end], length, model_delta(start, end),
                           previous_direction(start, end), sign_threshold, noise,
                           sign_margin, turn)
        points[end] = bone.end
        return bone

    solve(_S, _OS, lengths.shoulder_width)
    flexion = None
    if beliefs is not None and share_filter is not None:
        bones = []
        for k, (start, end, name) in enumerate(_ARM_BONES):
            bone, beliefs[k] = _filter_bone(points[start], rays[end], getattr(lengths, name),
                                            model_delta(start, end), beliefs[k], share_filter)
            points[end] = bone.end
            bones.append(bone)
        if share_filter.flexion_over_tilts <= 1.0:
            flexion = expected_flexion(points[_S], rays[_E], rays[_W],
                                       (lengths.upper_arm, lengths.forearm),
                                       (beliefs[0], beliefs[1]), share_filter,
                                       _DEPTH_RANGE[0])
    else:
        bones = [solve(start, end, getattr(lengths, name), keypoint_noise, float(turn))
                 for (start, end, name), turn in zip(_ARM_BONES, max_turn, strict=True)]
    side_to_hip = math.hypot(lengths.torso,
                             0.5 * lengths.shoulder_width * (1.0 - _HIP_WIDTH_RATIO))
    solve(_S, _HIP, side_to_hip)
    solve(_OS, _OHIP, side_to_hip)
    trust = float(confidence[[_S, _E, _W]].min())
    return (ArmPose(side, points, confidence, pixels, trust=trust, flexion=flexion),
            np.array([bone.lower_bound for bone in bones]),
            np.array([bone.overruled for bone in bones]))


class BoneLengthEstimator:
    """A person's arm lengths refined over a clip.

    Every lifted frame gives each bone a lower bound on its length: the distance from
    its start to its far end's ray (the bone's length were it square to the camera's
    axis). Over the frames seen, a high ``quantile`` of those bounds (robust to the
    keypoints' noise) is the length, once ``min_frames`` frames are in, kept within
    ``limits`` times the prior (a clip whose arm never lies in the image plane says little
    of its length). Before then, the prior.
    """

    def __init__(self, prior: BoneLengths, quantile: float = LENGTH_QUANTILE,
                 min_frames: int = 20,
                 limits: tuple[float, float] = (0.8, 1.4), memory: int = 3000) -> None:
        if not 0.0 < quantile <= 1.0:
            raise ValueError(f"quantile must be in (0, 1], got {quantile!r}")
        if not 0.0 < limits[0] <= limits[1]:
            raise ValueError(f"limits must be 0 < low <= high, got {limits!r}")
        self.prior, self.quantile, self.min_frames = prior, quantile, max(1, min_frames)
        self.limits = limits
        self.bounds: deque[np.ndarray] = deque(maxlen=memory)

    def reset(self) -> None:
        self.bounds.clear()

    def observe(self, bounds: np.ndarray) -> None:
        """One frame's (3,) lower bounds (metres) of upper arm, forearm, hand."""
        bounds = np.asarray(bounds, dtype=np.float64)
        if bounds.shape == (3,) and np.isfinite(bounds).all():
            self.bounds.append(bounds)

    @property
    def lengths(self) -> BoneLengths:
        if len(self.bounds) < self.min_frames:
            return self.prior
        seen = np.quantile(np.array(self.bounds), self.quantile, axis=0)
        prior = self.prior.arm
        refined = np.clip(seen, self.limits[0] * prior, self.limits[1] * prior)
        return replace(self.prior, upper_arm=float(refined[0]), forearm=float(refined[1]),
                       hand=float(refined[2]))


class ArmLifter:
    """The bone-length lift over a clip: `lift_arm` per frame, with the person's lengths
    refined as it goes (`BoneLengthEstimator`, one per arm), each arm bone's toward/away
    extent from a Bayes filter over the frames (`ShareFilter`; or, without it, the
    model's depth order with continuity and a turn limit), and a One Euro filter
    (`smoothing.OneEuroFilter`) on the lifted 3-D points (and, if asked, one on the 2-D
    keypoints before the lift).

    Args:
        intrinsics: the camera's.
        fps: frames/s, the step between calls when no time is given.
        lengths: the prior (None: `BoneLengths()`, an average adult).
        refine: refine the arm's lengths over the clip.
        smoothing: the One Euro settings of the 3-D points (metres; None: none).
        pixel_smoothing: those of the 2-D keypoints (pixels; None: none, the default:
            on synthetic clips its lag cost more than its smoothing gave).
        length_quantile: `BoneLengthEstimator`'s quantile.
        share_filter: the arm bones' Bayes filter (`SHARE_FILTER`); None: the sign
            rules below, one frame at a time.
        sign_threshold: see `SIGN_THRESHOLD` (without ``share_filter``).
        sign_margin: see `SIGN_MARGIN` (without ``share_filter``).
        keypoint_noise: see `lift_arm` (`KEYPOINT_NOISE`; without ``share_filter``).
        max_turn_rate: rad/s, `lift_arm`'s ``max_turn`` per second since the last
            reading (`MAX_TURN_RATE`; inf: no limit; without ``share_filter``).
        flip_patience: s; a bone whose model depth order has been overruled this long
            takes it (a wrong first choice is not kept for ever; `FLIP_PATIENCE`;
            without ``share_filter``).
    """

    def __init__(self, intrinsics: Intrinsics, fps: float = 30.0,
                 lengths: BoneLengths | None = None, refine: bool = True,
                 smoothing: OneEuroSettings | None = ONE_EURO,
                 pixel_smoothing: OneEuroSettings | None = None,
                 sign_threshold: float = SIGN_THRESHOLD, sign_margin: float = SIGN_MARGIN,
                 keypoint_noise: float = KEYPOINT_NOISE,
                 length_quantile: float = LENGTH_QUANTILE,
                 max_turn_rate: float = MAX_TURN_RATE,
                 flip_patience: float = FLIP_PATIENCE,
                 share_filter: ShareFilter | None = SHARE_FILTER) -> None:
        if not (math.isfinite(fps) and fps > 0):
            raise ValueError(f"fps must be a positive number, got {fps!r}")
        self.share_filter = share_filter
        self.intrinsics, self.fps, self.refine = intrinsics, float(fps), refine
        self.prior = lengths if lengths is not None else BoneLengths()
        self.smoothing, self.pixel_smoothing = smoothing, pixel_smoothing
        self.sign_threshold, self.sign_margin = sign_threshold, sign_margin
        self.keypoint_noise = keypoint_noise
        self.max_turn_rate, self.flip_patience = max_turn_rate, flip_patience
        self.estimators = {side: BoneLengthEstimator(self.prior, quantile=length_quantile)
                           for side in ("left", "right")}
        self.filter = OneEuroFilter(smoothing)
        self.pixel_filter = OneEuroFilter(pixel_smoothing)
        self.reset()

    def reset(self) -> None:
        for estimator in self.estimators.values():
            estimator.reset()
        self.filter.reset()
        self.pixel_filter.reset()
        self.previous: ArmPose | None = None
        self.time: float | None = None
        self.calls = 0
        self.overruled_for = np.zeros(len(_ARM_BONES))  # s, per arm bone
        self.beliefs = [uniform_belief() for _ in _ARM_BONES]  # `ShareFilter`'s

    def lengths(self, side: str) -> BoneLengths:
        """The lengths in use for the arm ``side``."""
        return self.estimators[side].lengths if self.refine else self.prior

    def __call__(self, side: str, pixels: np.ndarray, confidence: np.ndarray,
                 depth: np.ndarray | None = None, time_s: float | None = None) -> ArmPose:
        """The next reading's pose (arguments as `lift_arm`'s; ``time_s``: its time in
        the video, s, None: one frame after the last call). The pose's ``pixels`` are
        the keypoints as given."""
        pixels, confidence = _check_inputs(side, pixels, confidence)
        now = self.calls / self.fps if time_s is None else float(time_s)
        self.calls += 1
        previous = self.previous if (self.previous is not None
                                     and self.previous.side == side) else None
        dt = now - self.time if self.time is not None else 0.0
        if previous is None or not dt > 0:  # another arm, or time went back: start afresh
            self.filter.reset()
            self.pixel_filter.reset()
            self.overruled_for[:] = 0.0
            dt = 1.0 / self.fps
            self.beliefs = [uniform_belief() for _ in _ARM_BONES]
        elif self.share_filter is not None:
            self.beliefs = [predict_belief(belief, self.share_filter, dt)
                            for belief in self.beliefs]
        max_turn = np.where(self.overruled_for >= self.flip_patience - 1e-9, math.inf,
                            self.max_turn_rate * dt)
        smoothed = (self.pixel_filter.filter(pixels, dt) if self.pixel_smoothing is not None
                    else pixels)
        pose, bounds, overruled = _lift(side, smoothed, confidence, depth, self.intrinsics,
                                        self.lengths(side), None, previous,
                                        self.sign_threshold, self.sign_margin,
                                        self.keypoint_noise, max_turn,
                                        self.beliefs, self.share_filter)
        self.overruled_for = np.where(overruled, self.overruled_for + dt, 0.0)
        self.estimators[side].observe(bounds)
        points = (self.filter.filter(pose.points, dt) if self.smoothing is not None
                  else pose.points)
        flexion = None
        if pose.flexion is not None:  # the smoothed bones' angle, offset as the lift's was
            smoothed_bend = float(angle_between(points[_E] - points[_S], points[_W] - points[_E]))
            bent = float(angle_between(pose.upper_arm, pose.forearm))
            flexion = float(np.clip(smoothed_bend + pose.flexion - bent, 0.0, math.pi))
        pose = ArmPose(side, points, pose.confidence, pixels, pose.trust, flexion=flexion)
        self.previous, self.time = pose, now
        return pose


def from_depth(side: str, pixels: np.ndarray, confidence: np.ndarray,
               depth_image: np.ndarray, intrinsics: Intrinsics, window: int | None = None,
               fallback: ArmPose | None = None, lengths: np.ndarray | None = None,
               length_tolerance: float = 0.25) -> ArmPose:
    """An arm back-projected through a metric depth image.

    Args:
        side, pixels, confidence: as `lift_arm`'s.
        depth_image: (H, W) float metres along the camera's axis, the intrinsics' size;
            0 or not finite where the camera measured nothing.
        intrinsics: the depth image's camera (registered to the colour image).
        window: each keypoint's depth is the nearer quarter's edge (the 25th
            percentile) of the valid depths within this many pixels of it (a
            (2 window + 1)^2 square; None: 1% of the image's diagonal, at least 2), plus
            its limb's radius (`LIMB_RADIUS`: the camera sees the limb's surface, not its
            axis). The nearer quarter, not the median: a keypoint on a limb's or the
            body's outline has the wall behind half its window. A shoulder more than
            `_BEHIND` m behind the other body keypoints' median depth (the window missed
            the body) takes that median; one more than `_IN_FRONT` m in front of both
            its own hip and the other shoulder (the window saw a hand before it) takes
            the nearer of their depths.
        fallback: where a keypoint has no valid depth, this pose's point (None: the
            median depth of the keypoints found, confidence 0; `DEFAULT_DEPTH` if none).
        lengths: (3,) metres of upper arm, forearm and hand, or None. Given, an arm bone
            whose far end has no depth, or whose back-projected length is off by more
            than ``length_tolerance`` of it (the window saw something else: the hand in
            front of the elbow, the wall behind a thin wrist), is solved as the lift
            solves it: on its far end's ray at its length from its start, toward or away
            as the measured depth says (`lift_arm`); a far end read over `_BEHIND` m
            behind the torso's median depth (its window missed the limb and saw the
            wall) says neither, and the root toward the camera is taken.

    Returns:
        The `ArmPose`, ``trust`` the least confidence of shoulder, elbow and wrist.
    """
    pixels, confidence = _check_inputs(side, pixels, confidence)
    depth_image = np.asarray(depth_image)
    if depth_image.shape != (intrinsics.height, intrinsics.width):
        raise ValueError(f"from_depth: the depth image is {depth_image.shape}, the "
                         f"intrinsics are for ({intrinsics.height}, {intrinsics.width})")
    h, w = depth_image.shape
    if window is None:
        window = max(2, round(0.01 * math.hypot(w, h)))
    depths = np.full(len(ARM_POINTS), np.nan)
    for i, (x, y) in enumerate(pixels):
        col, row = round(x), round(y)
        patch = depth_image[max(row - window, 0):max(row + window + 1, 0),
                            max(col - window, 0):max(col + window + 1, 0)]
        valid = patch[np.isfinite(patch) & (patch > 0)] if 0 <= row < h and 0 <= col < w \
            else np.empty(0)
        if valid.size:
            depths[i] = float(np.percentile(valid, 25)) + LIMB_RADIUS[i]
    body = depths[[_E, _OS, _HIP, _OHIP]]
    body = body[np.isfinite(body)]
    if body.size and np.isfinite(depths[_S]) and depths[_S] > np.median(body) + _BEHIND:
        depths[_S] = float(np.median(body))
    torso = [depths[i] for i in (_OS, _HIP) if np.isfinite(depths[i]) and confidence[i] >= 0.5]
    if torso and np.isfinite(depths[_S]) and depths[_S] < min(torso) - _IN_FRONT:
        depths[_S] = float(min(torso))
    found = np.isfinite(depths)
    points = intrinsics.back_project(pixels, np.where(found, depths, 1.0))
    confidence = confidence.copy()
    if fallback is not None:
        points[~found] = fallback.points[~found]
    else:
        points[~found] = intrinsics.back_project(
            pixels[~found], np.full((~found).sum(),
                                    float(np.median(depths[found])) if found.any()
                                    else DEFAULT_DEPTH))
        confidence[~found] = 0.0
    if lengths is not None:
        rays = intrinsics.rays(pixels)
        trunk = depths[[_S, _OS, _HIP, _OHIP]]
        trunk = trunk[np.isfinite(trunk)]
        wall = float(np.median(trunk)) + _BEHIND if trunk.size else math.inf
        for (start, end, _), length in zip(_ARM_BONES, np.asarray(lengths, float),
                                           strict=True):
            measured = float(np.linalg.norm(points[end] - points[start]))
            if found[end] and abs(measured - length) <= length_tolerance * length:
                continue
            delta = (float(depths[end] - points[start, 2])
                     if found[end] and depths[end] <= wall else None)
            points[end] = _solve_bone(points[start], rays[end], length, delta, None,
                                      0.0).end
            confidence[end] = confidence[end] if found[end] else 0.0
    trust = float(confidence[[_S, _E, _W]].min())
    return ArmPose(side, points, confidence, pixels, trust=trust)


def from_world_landmarks(side: str, world: np.ndarray, pixels: np.ndarray,
                         confidence: np.ndarray, intrinsics: Intrinsics,
                         depth_of_shoulder: float | None = None,
                         lengths: BoneLengths | None = None) -> ArmPose:
    """The pose model's world landmarks as an `ArmPose`.

    MediaPipe's world landmarks (metres, origin at the hips' middle) have the image's
    axes (x right, y down, z away from the camera; checked on our development clips), so
    they keep their directions: the points are shifted so the shoulder sits on its
    pixel's ray at ``depth_of_shoulder`` (None: `shoulder_depth` from ``lengths``, as the
    lift places it).

    Args:
        side, pixels, confidence: as `lift_arm`'s.
        world: (7, 3) metres, `ARM_POINTS` order.
    """
    pixels, confidence = _check_inputs(side, pixels, confidence)
    world = np.asarray(world, dtype=np.float64)
    if world.shape != (len(ARM_POINTS), 3) or not np.isfinite(world).all():
        raise ValueError(f"world landmarks must be finite with shape ({len(ARM_POINTS)}, 3), "
                         f"got {world.shape}")
    if depth_of_shoulder is None:
        depth_of_shoulder = shoulder_depth(pixels, confidence, intrinsics,
                                           lengths if lengths is not None else BoneLengths())
    anchor = float(np.clip(depth_of_shoulder, *_DEPTH_RANGE)) * intrinsics.rays(pixels[_S])
    points = world - world[_S] + anchor
    trust = float(confidence[[_S, _E, _W]].min())
    return ArmPose(side, points, confidence, pixels, trust=trust)


def neutral_pose(side: str, intrinsics: Intrinsics, lengths: BoneLengths | None = None,
                 depth: float = DEFAULT_DEPTH) -> ArmPose:
    """A person facing the camera ``depth`` metres away in the image's middle, both arms
    hanging straight down at their sides, their torso's middle on the optical axis, confidence 0 and
    trust 0: the pose before any reading."""
    if side not in ("left", "right"):
        raise ValueError(f"side must be 'left' or 'right', got {side!r}")
    lengths = lengths if lengths is not None else BoneLengths()
    centre = np.array([0.0, 0.0, depth])  # on the optical axis
    # A person facing the camera has their left on the image's right (+x).
    out = 1.0 if side == "left" else -1.0
    half, hip_half = 0.5 * lengths.shoulder_width, 0.5 * lengths.shoulder_width * _HIP_WIDTH_RATIO
    top, bottom = -0.5 * lengths.torso, 0.5 * lengths.torso
    arm_down = np.cumsum([0.0, lengths.upper_arm, lengths.forearm, lengths.hand])
    offsets = np.array([[out * half, top + drop, 0.0] for drop in arm_down]
                       + [[-out * half, top, 0.0], [out * hip_half, bottom, 0.0],
                          [-out * hip_half, bottom, 0.0]])
    points = centre + offsets
    return ArmPose(side, points, np.zeros(len(ARM_POINTS)), intrinsics.project(points),
                   trust=0.0)
