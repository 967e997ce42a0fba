"""Task-space retargeting through mink (MuJoCo differential IK; the ``ik`` extra).

Frames: the person's directions are read in their **arm frame** (rows forward, outward,
up) and taken into the **robot base frame** (x forward, y left, z up; metres) by a
`PersonToRobot` mapping. The targets are positions of the robot's sites: the elbow site
one robot upper arm (0.116 m) from the robot's shoulder site along the person's upper
arm, the wrist site one robot forearm (0.135 m) further along the person's forearm, the
tool site one robot hand (wrist to tool) further along the person's hand. IK weighs these
(``elbow_cost``, ``wrist_cost``, ``tool_cost``) with a posture task toward the previous
targets and stays inside the joint ranges (mink's configuration limit, then a clip), so
where the robot's planar arm cannot take both directions it trades them off by the costs
(locally, from the previous targets; `DirectionRetargeter` weighs the two directions'
angles and searches all arm planes).

Joint targets (6,) rad in `SO101Spec.joint_names` order.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import mink
import mujoco
import numpy as np

from imimic_gym.retarget.directions import DirectionRetargeter
from imimic_gym.retarget.mapping import MIRROR, PersonToRobot
from imimic_gym.robots.so101 import SO101Spec
from imimic_gym.spatial.arm_pose import ArmPose, unit

__all__ = ["MinkRetargeter"]

_ROLL, _GRIP = 4, 5
# QP solver for mink (qpsolvers' daqp, small and dependency-free).
_SOLVER = "daqp"


@dataclass(frozen=True)
class MinkRetargeter:
    """Person's arm -> SO-101 joint targets by differential IK (module docstring).

    ``previous`` (6,) rad seeds the solve and is the posture task's target; without it
    the first frame is seeded by `DirectionRetargeter` (IK from a far pose can settle in
    the wrong one of the robot's two ways to point its upper arm). Each call runs at most
    ``iterations`` IK steps, stopping once the elbow and wrist sites are within
    ``tolerance`` metres of their targets. wrist_roll and gripper hold ``wrist_roll``
    and ``gripper`` (rad).
    """

    spec: SO101Spec = field(default_factory=SO101Spec)
    mapping: PersonToRobot = MIRROR
    wrist_roll: float = 0.0
    gripper: float = 0.0
    elbow_cost: float = 1.0
    wrist_cost: float = 1.0
    tool_cost: float = 0.01
    posture_cost: float = 1e-4
    iterations: int = 60
    tolerance: float = 2e-5
    step: float = 0.1
    damping: float = 1e-4

    @cached_property
    def _solver_parts(self) -> tuple[mink.Configuration, list, list]:
        model = self.spec.build_model()
        configuration = mink.Configuration(model)
        sites = [mink.FrameTask(name, "site", position_cost=cost, orientation_cost=0.0)
                 for name, cost in ((self.spec.elbow_site, self.elbow_cost),
                                    (self.spec.wrist_site, self.wrist_cost),
                                    (self.spec.tool_site, self.tool_cost))]
        posture_costs = np.full(model.nv, self.posture_cost)
        posture_costs[[_ROLL, _GRIP]] = 1.0  # held, not retargeted
        posture = mink.PostureTask(model, cost=posture_costs)
        return configuration, [*sites, posture], [mink.ConfigurationLimit(model)]

    @cached_property
    def _link_lengths(self) -> np.ndarray:
        """(3,) metres: robot upper arm, forearm, wrist to tool (at q = 0)."""
        sites = self.spec.forward_kinematics(np.zeros(len(self.spec.joint_names)))
        chain = [sites[name] for name in self.spec.site_names]
        return np.linalg.norm(np.diff(chain, axis=0), axis=1)

    @cached_property
    def _seed(self) -> DirectionRetargeter:
        return DirectionRetargeter(self.spec, self.mapping, self.wrist_roll, self.gripper)

    def __call__(self, pose: ArmPose, previous: np.ndarray | None = None) -> np.ndarray:
        """(6,) float64 rad joint targets for ``pose``, inside the joint ranges;
        ``previous``: (6,) rad, the last targets (None at the first frame)."""
        directions = [unit(self.mapping.to_robot(pose.in_arm_frame(d)))
                      for d in (pose.upper_arm, pose.forearm, pose.hand)]
        start = self._seed(pose, None) if previous is None else self.spec.clip(previous)
        start[_ROLL], start[_GRIP] = self.wrist_roll, self.gripper
        configuration, tasks, limits = self._solver_parts
        configuration.update(start)
        site_tasks, posture = tasks[:3], tasks[3]
        posture.set_target(start)
        for _ in range(self.iterations):
            if self._aim(configuration, site_tasks, directions) < self.tolerance:
                break
            velocity = mink.solve_ik(configuration, tasks, self.step, _SOLVER,
                                     damping=self.damping, limits=limits)
            configuration.integrate_inplace(velocity, self.step)
        return self.spec.clip(configuration.q.copy())

    def _aim(self, configuration: mink.Configuration, site_tasks: list,
             directions: list[np.ndarray]) -> float:
        """Set each site task's target from the robot's current shoulder position (the
        chain: shoulder + lengths along the person's directions, orientation left as the
        site's own) and return the elbow's and wrist's largest distance to target, m."""
        data: mujoco.MjData = configuration.data
        shoulder = data.site(self.spec.shoulder_site).xpos.copy()
        targets = shoulder + np.cumsum(self._link_lengths[:, None] * np.array(directions),
                                       axis=0)
        for task, name, target in zip(site_tasks, self.spec.site_names[1:], targets,
                                      strict=True):
            rotation = mink.SO3.from_matrix(data.site(name).xmat.reshape(3, 3).copy())
            task.set_target(mink.SE3.from_rotation_and_translation(rotation, target))
        reached = [np.linalg.norm(data.site(name).xpos - target)
                   for name, target in zip(self.spec.site_names[1:3], targets[:2],
                                           strict=True)]
        return float(max(reached))
