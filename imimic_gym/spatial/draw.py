"""Pictures of an `ArmPose`: the arm seen from the person's side, so depth shows."""

from __future__ import annotations

from itertools import pairwise

import cv2
import numpy as np

from imimic_gym.spatial.arm_pose import ArmPose

__all__ = ["draw_side_view"]

_ARM = ("shoulder", "elbow", "wrist", "hand")
_INK, _TORSO, _PAPER = (255, 220, 0), (150, 150, 160), (30, 30, 35)


def draw_side_view(picture: np.ndarray, pose: ArmPose, size: int | None = None,
                   in_place: bool = False) -> np.ndarray:
    """``picture`` (H, W, 3) uint8 RGB with a square inset in its bottom-left corner: the
    arm seen from the person's side, in the arm frame's (forward, up) plane: forward to the
    inset's right, up to its top, the shoulder at its middle, the torso as a grey line
    down from it; a yellow line for the upper arm, forearm and hand. ``size``: the inset's
    side in pixels (default: a third of the picture's height). A copy is returned, or
    ``picture`` itself drawn on with ``in_place``."""
    out = picture if in_place else picture.copy()
    height = out.shape[0]
    side = size or max(48, height // 3)
    inset = np.full((side, side, 3), _PAPER, dtype=np.uint8)
    frame = pose.arm_frame()
    points = np.array([pose.point(name) for name in _ARM]) - pose.point("shoulder")
    local = points @ frame.T  # (forward, outward, up) metres
    reach = max(float(np.linalg.norm(points[1:] - points[:-1], axis=1).sum()), 1e-6)
    scale = 0.45 * side / reach
    centre = np.array([side / 2, side / 2])

    def pixel(forward: float, up: float) -> tuple[int, int]:
        x, y = centre + scale * np.array([forward, -up])
        return round(float(x)), round(float(y))

    line = max(1, side // 40)
    cv2.line(inset, pixel(0, 0), pixel(0, -0.8 * reach), _TORSO, line + 1, cv2.LINE_AA)
    for start, end in pairwise(local):
        cv2.line(inset, pixel(start[0], start[2]), pixel(end[0], end[2]), _INK, line + 1,
                 cv2.LINE_AA)
    for point in local[:3]:
        cv2.circle(inset, pixel(point[0], point[2]), line + 2, _INK, -1, cv2.LINE_AA)
    cv2.putText(inset, "side view", (4, side - 6), cv2.FONT_HERSHEY_SIMPLEX, side / 400,
                (200, 200, 200), 1, cv2.LINE_AA)
    cv2.putText(inset, "front >", (side - int(side * 0.42), 14), cv2.FONT_HERSHEY_SIMPLEX,
                side / 400, (200, 200, 200), 1, cv2.LINE_AA)
    out[height - side:, :side] = inset
    return out
