"""The spatial demonstrator's arm motions ("gestures"): its five joint angles over a clip.

The spatial arm (`SPATIAL_JOINTS`, the demonstrator's left arm; angles in rad, all 0 with
the arm hanging straight down by the side, thumb forward, palm towards the thigh):

- ``shoulder_flexion``: the arm swung forward (+) or backward (-) about the torso's
  lateral axis;
- ``shoulder_abduction``: then swung sideways away from the body (+) about the
  forward axis as flexion has turned it;
- ``shoulder_rotation``: then turned about the upper arm's own long axis, internal (+:
  a forearm bent forward turns towards the belly) or external (-);
- ``elbow_flexion``: the forearm bent forward from straight (0);
- ``wrist_flexion``: the hand bent towards the palm (+) or the back of the hand (-).

The shoulder's three rotations are applied in that order (intrinsic: flexion about the
torso's axis, abduction about the once-rotated forward axis, rotation about the
twice-rotated long axis), as the demonstrator's MJCF nests its joints.

Every gesture is a sequence of key poses drawn from the seeded generator, joined by
minimum-jerk moves (all joints together, zero velocity and acceleration at each key pose)
and holds; angles, velocities and accelerations are analytic.
"""

from __future__ import annotations

import math
from typing import Literal

import numpy as np

__all__ = ["GESTURES", "SPATIAL_JOINTS", "SPATIAL_JOINT_RANGES", "Gesture", "sample_gesture"]

Gesture = Literal["reach", "cup", "raise", "curl", "wave", "mix"]
GESTURES: tuple[str, ...] = ("reach", "cup", "raise", "curl", "wave", "mix")
SPATIAL_JOINTS = ("shoulder_flexion", "shoulder_abduction", "shoulder_rotation",
                  "elbow_flexion", "wrist_flexion")
_DEG = math.pi / 180
# Active ranges of motion of a healthy adult (rad; the AAOS's figures, rounded): the
# joints' limits in the MJCF, and the bounds every gesture's key poses stay inside.
SPATIAL_JOINT_RANGES = ((-50 * _DEG, 180 * _DEG), (-30 * _DEG, 180 * _DEG),
                        (-90 * _DEG, 70 * _DEG), (0.0, 150 * _DEG), (-70 * _DEG, 80 * _DEG))

# (key pose in degrees, per joint (low, high) to draw from), the move there (s) and the
# hold there (s), each drawn from its (low, high).
Key = tuple[tuple[tuple[float, float], ...], tuple[float, float], tuple[float, float]]
_REST: Key = (((0, 10), (8, 15), (-10, 10), (10, 25), (-10, 10)), (0.8, 1.2), (0.2, 0.5))


def _reach() -> list[Key]:
    """The hand pushed out towards the camera at shoulder height, and back."""
    out = ((80, 95), (5, 15), (-10, 10), (0, 12), (-15, 5))
    return [(out, (0.9, 1.3), (0.3, 0.6)), _REST]


def _cup() -> list[Key]:
    """The hand brought to the mouth (a cup held there), and back down."""
    mouth = ((68, 76), (0, 6), (50, 56), (130, 136), (-12, -2))
    return [(mouth, (1.0, 1.4), (0.4, 0.8)), _REST]


def _raise() -> list[Key]:
    """The straight arm raised sideways above the shoulder, and lowered."""
    up = ((0, 15), (110, 140), (-30, -10), (0, 15), (-10, 10))
    return [(up, (1.0, 1.4), (0.3, 0.6)), _REST]


def _curl() -> list[Key]:
    """The forearm curled up with the upper arm by the side, and lowered: twice."""
    top = ((5, 15), (5, 12), (-10, 5), (125, 140), (0, 15))
    bottom = ((0, 10), (5, 12), (-10, 5), (5, 15), (-10, 5))
    return [(top, (0.7, 1.0), (0.1, 0.3)), (bottom, (0.7, 1.0), (0.1, 0.3))] * 2


def _wave() -> list[Key]:
    """The upper arm out sideways, the forearm up, swinging side to side (the elbow
    opening and closing) three times, then lowered."""
    # External rotation turns the elbow's axis to point forward, so bending it swings the
    # forearm in the body's frontal plane, the way a wave looks from the front.
    def side(elbow: tuple[float, float]) -> tuple[tuple[float, float], ...]:
        return ((10, 20), (75, 85), (-85, -75), elbow, (-10, 10))
    keys: list[Key] = [(side((70, 80)), (0.8, 1.1), (0.0, 0.1))]
    for _ in range(3):
        keys += [(side((105, 120)), (0.25, 0.35), (0.0, 0.05)),
                 (side((40, 55)), (0.25, 0.35), (0.0, 0.05))]
    return [*keys, _REST]


_GESTURE_KEYS = {"reach": _reach, "cup": _cup, "raise": _raise, "curl": _curl,
                 "wave": _wave}


def _draw(key: Key, rng: np.random.Generator) -> tuple[np.ndarray, float, float]:
    pose_deg, move, hold = key
    pose = np.array([rng.uniform(lo, hi) for lo, hi in pose_deg]) * _DEG
    return pose, float(rng.uniform(*move)), float(rng.uniform(*hold))


def sample_gesture(gesture: Gesture, n_frames: int, fps: float, rng: np.random.Generator
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``gesture`` repeated from the rest pose until the clip's end ("mix": a different
    gesture each time, drawn from ``rng``).

    Returns:
        angle (T, 5) rad in `SPATIAL_JOINTS` order, angular velocity (T, 5) rad/s,
        angular acceleration (T, 5) rad/s^2.
    """
    if gesture not in GESTURES:
        raise ValueError(f"unknown gesture {gesture!r}; expected one of {GESTURES}")
    t = np.arange(n_frames) / float(fps)
    rest, _, first_hold = _draw(_REST, rng)
    # Segments (start time, duration, from pose, to pose); a hold moves from a pose to itself.
    starts, durations, froms, tos = [0.0], [first_hold], [rest], [rest]
    clock, pose = first_hold, rest
    order = [g for g in GESTURES if g != "mix"]
    while clock <= t[-1]:
        name = order[int(rng.integers(len(order)))] if gesture == "mix" else gesture
        for key in _GESTURE_KEYS[name]():
            target, move, hold = _draw(key, rng)
            for duration, end in ((move, target), (hold, target)):
                if duration > 0:
                    starts.append(clock)
                    durations.append(duration)
                    froms.append(pose)
                    tos.append(end)
                    clock, pose = clock + duration, end
    seg = np.searchsorted(np.asarray(starts), t, side="right") - 1
    q0, dq = np.asarray(froms)[seg], np.asarray(tos)[seg] - np.asarray(froms)[seg]
    dur = np.asarray(durations)[seg][:, None]
    s = (t - np.asarray(starts)[seg])[:, None] / dur
    angle = q0 + dq * (10 * s**3 - 15 * s**4 + 6 * s**5)
    velocity = dq / dur * (30 * s**2 - 60 * s**3 + 30 * s**4)
    acceleration = dq / dur**2 * (60 * s - 180 * s**2 + 120 * s**3)
    return angle, velocity, acceleration
