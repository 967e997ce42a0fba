"""Hand-made human arms for the retargeting tests: ArmPoses built from arm-frame
directions, for a person facing the camera 2 m away."""

import math

import numpy as np

from imimic_gym.spatial import ArmPose

# Arm-frame rows (forward, outward, up) in camera coordinates for a person facing the
# camera: forward is toward the camera (-z), up is -y; outward is the camera's -x for the
# right arm, +x for the left.
FRAMES = {"right": np.array([[0.0, 0, -1], [-1, 0, 0], [0, -1, 0]]),
          "left": np.array([[0.0, 0, -1], [1, 0, 0], [0, -1, 0]])}
LENGTHS = (0.29, 0.26, 0.08)  # upper arm, forearm, wrist to hand, metres


def arm_pose(upper: np.ndarray, fore: np.ndarray, hand: np.ndarray | None = None,
             side: str = "right") -> ArmPose:
    """An ArmPose whose upper arm, forearm and hand point along the given arm-frame unit
    directions (3,)."""
    frame = FRAMES[side]
    hand = fore if hand is None else hand
    shoulder = np.array([0.0, 0.0, 2.0])
    other_shoulder = shoulder - 0.38 * frame[1]
    waist = 0.5 * (shoulder + other_shoulder) - 0.5 * frame[2]
    elbow = shoulder + LENGTHS[0] * (np.asarray(upper) @ frame)
    wrist = elbow + LENGTHS[1] * (np.asarray(fore) @ frame)
    tip = wrist + LENGTHS[2] * (np.asarray(hand) @ frame)
    points = np.array([shoulder, elbow, wrist, tip, other_shoulder,
                       waist + 0.15 * frame[1], waist - 0.15 * frame[1]])
    return ArmPose(side, points, np.ones(7), np.zeros((7, 2)))


def direction(elevation: float, azimuth: float) -> np.ndarray:
    """(3,) arm-frame unit vector: ``elevation`` rad above the horizontal, ``azimuth`` rad
    from forward toward outward."""
    return np.array([math.cos(elevation) * math.cos(azimuth),
                     math.cos(elevation) * math.sin(azimuth), math.sin(elevation)])


def rotate_about(v: np.ndarray, axis: np.ndarray, angle: float) -> np.ndarray:
    """``v`` rotated by ``angle`` rad about unit ``axis`` (Rodrigues)."""
    axis = axis / np.linalg.norm(axis)
    return (v * math.cos(angle) + np.cross(axis, v) * math.sin(angle)
            + axis * float(axis @ v) * (1 - math.cos(angle)))


def human_arm(rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray, float]:
    """A random arm from human ranges, arm frame: the upper arm anywhere a shoulder takes
    it (not more than 40 degrees across the body, not more than 60 behind it), the elbow
    flexed 0-150 degrees, the forearm at any turn about the upper arm. Returns (upper (3,),
    fore (3,), flexion rad)."""
    while True:
        upper = rng.normal(size=3)
        upper /= np.linalg.norm(upper)
        if upper[1] >= -math.sin(math.radians(40)) and upper[0] >= -math.sin(math.radians(60)):
            break
    flexion = rng.uniform(0.0, math.radians(150))
    side = np.cross(upper, rng.normal(size=3))
    fore = rotate_about(upper, side, flexion)
    return upper, fore, flexion
