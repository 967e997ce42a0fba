"""Angles shared by the estimators, the truth and the controllers.

Convention (`imimic_gym.robots.planar`): angles in rad, counter-clockwise positive with the image's
y axis pointing up; a link's joint angle is its image direction minus its parent's (the
reference direction for the root). Pixels are (x, y), x right, y down.
"""

from __future__ import annotations

import math
from typing import overload

import numpy as np

__all__ = ["keypoints_to_angles", "wrap_angle"]


@overload
def wrap_angle(angle: float) -> float: ...
@overload
def wrap_angle(angle: np.ndarray) -> np.ndarray: ...
@overload
def wrap_angle(angle: np.ndarray | float) -> np.ndarray | float: ...
def wrap_angle(angle: np.ndarray | float) -> np.ndarray | float:
    """Wrap radians into [-pi, pi), so 359 degrees of error counts as -1 degree.

    A Python float gives a float, by the same arithmetic (Python's float modulo rounds
    as numpy's does) at a tenth of the cost: estimators wrap one angle per frame."""
    if type(angle) is float:
        return (angle + math.pi) % math.tau - math.pi
    return (np.asarray(angle) + np.pi) % (2 * np.pi) - np.pi


def keypoints_to_angles(keypoints: np.ndarray, n_links: int,
                        reference_direction: float = -math.pi / 2) -> np.ndarray:
    """Joint angles (the `imimic_gym.robots.planar` convention) from shoulder, elbow, wrist pixels.

    Args:
        keypoints: (..., 3, 2) pixel (x, y) of shoulder, elbow, wrist (image y down).
        n_links: 1 (the forearm: q1 = forearm from the upper arm, whose direction is
            measured, not assumed) or 2 (q1 = upper arm from ``reference_direction``, the
            torso's axis in the image, rad CCW from image right; q2 = forearm from the upper
            arm). The torso's roll is not in the keypoints: with body sway it adds to q1's
            error.
    Returns:
        (..., n_links) float64 rad in [-pi, pi), counter-clockwise positive.
    """
    k = np.asarray(keypoints, dtype=np.float64)
    if k.shape[-2:] != (3, 2):
        raise ValueError(f"keypoints must have shape (..., 3, 2), got {k.shape}")
    delta = np.diff(k, axis=-2)
    direction = np.arctan2(-delta[..., 1], delta[..., 0])  # CCW, image up
    forearm = wrap_angle(direction[..., 1] - direction[..., 0])
    if n_links == 1:
        return forearm[..., None]
    if n_links == 2:
        return np.stack([wrap_angle(direction[..., 0] - reference_direction), forearm], axis=-1)
    raise ValueError(f"shoulder, elbow and wrist give 1 or 2 joint angles, not {n_links}")
