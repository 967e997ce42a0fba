"""How a person's arm maps onto the robot: a named, explicit choice.

Frames: the person's **arm frame** (rows forward, outward, up; `spatial.arm_pose`) and the
**robot base frame** (x forward, y the robot's left, z up; `robots.so101`). A mapping is a
rotation taking arm-frame coordinates to robot-base-frame coordinates; the robot's
shoulder stands in for the person's shoulder. docs/decisions/retargeting.md says why
"mirror" is the default and what happens to directions the robot cannot reach.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["MAPPINGS", "MIRROR", "TILTED", "PersonToRobot"]


@dataclass(frozen=True)
class PersonToRobot:
    """A named person-to-robot mapping.

    Attributes:
        name: shown in ``--help`` and logs.
        robot_from_arm: (3, 3) rotation, rows; robot-base-frame direction =
            ``robot_from_arm @ arm-frame direction``.
        description: one line for ``--help``.
    """

    name: str
    robot_from_arm: tuple[tuple[float, float, float], ...]
    description: str

    def __post_init__(self) -> None:
        rotation = self.matrix
        if rotation.shape != (3, 3) or not np.allclose(rotation @ rotation.T, np.eye(3),
                                                       atol=1e-9) \
                or np.linalg.det(rotation) < 0:
            raise ValueError(f"PersonToRobot {self.name!r}: robot_from_arm must be a (3, 3) "
                             f"rotation, got {self.robot_from_arm}")

    @property
    def matrix(self) -> np.ndarray:
        """(3, 3) float64 `robot_from_arm`."""
        return np.asarray(self.robot_from_arm, dtype=np.float64)

    def to_robot(self, arm_directions: np.ndarray) -> np.ndarray:
        """(..., 3) arm-frame directions -> robot base frame."""
        return np.asarray(arm_directions, dtype=np.float64) @ self.matrix.T

    def to_arm(self, robot_directions: np.ndarray) -> np.ndarray:
        """(..., 3) robot-base-frame directions -> arm frame (the inverse of `to_robot`)."""
        return np.asarray(robot_directions, dtype=np.float64) @ self.matrix


MIRROR = PersonToRobot(
    "mirror", ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)),
    "the robot faces the person like their mirror image: the person's forward, outward and "
    "up are the robot's forward, left and up")
# rad: how far "tilted" turns the person's arm frame forward-up about the outward axis.
_TILT = math.radians(66.0)
TILTED = PersonToRobot(
    "tilted",
    ((math.cos(_TILT), 0.0, -math.sin(_TILT)), (0.0, 1.0, 0.0),
     (math.sin(_TILT), 0.0, math.cos(_TILT))),
    "as mirror, turned 66 degrees forward-up about the outward axis: a hanging arm points "
    "forward-down, an arm reaching forward points up, so a relaxed arm stays in reach")
MAPPINGS: dict[str, PersonToRobot] = {MIRROR.name: MIRROR, TILTED.name: TILTED}
