"""`RobotSpec`: what the env, the controllers and the renderer read of a robot, whatever
its kind (the planar `arms.ArmSpec`, the spatial `robots.so101.SO101Spec`)."""

from __future__ import annotations

from typing import Protocol

import mujoco

__all__ = ["RobotSpec"]


class RobotSpec(Protocol):
    """A robot description.

    Attributes:
        name: what the robot is called (``"planar"``, ``"so101"``).
        joint_names: its joints' names, in qpos and actuator order (LeRobot's for the
            SO-101).
        joint_ranges: one (low, high) per joint, rad, in qpos and actuator order.
        control: how its actuators are driven: ``"position"``, ``"velocity"`` or
            ``"torque"`` (an action of -1..1 maps onto each actuator's ctrl range).
        n_joints: how many joints (= actuators = qpos entries).
        link_parents: each joint's parent joint, -1 for the first (a chain: 0, 1, ...).
    """

    @property
    def name(self) -> str: ...

    @property
    def joint_names(self) -> tuple[str, ...]: ...

    @property
    def joint_ranges(self) -> tuple[tuple[float, float], ...]: ...

    @property
    def control(self) -> str: ...

    @property
    def n_joints(self) -> int: ...

    @property
    def link_parents(self) -> tuple[int, ...]: ...

    def build_model(self) -> mujoco.MjModel:
        """The robot compiled, with a camera named ``robot`` that frames it."""
