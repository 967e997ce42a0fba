"""ImitateVideo3D-v0: an SO-101 arm copies a human arm that moves in space, seen on video."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import mujoco
import numpy as np
from gymnasium.utils import EzPickle

from imimic_gym.clips.scenarios import ClipSpec
from imimic_gym.clips.types import Clip
from imimic_gym.envs.imitate_video import ImitateVideoEnv
from imimic_gym.estimators.types import Estimate, EstimatorContext
from imimic_gym.metrics import direction_error_deg
from imimic_gym.retarget import MAPPINGS, DirectionRetargeter
from imimic_gym.robots.planar import Control
from imimic_gym.robots.so101 import SO101Spec
from imimic_gym.spatial.arm_pose import angle_between, unit
from imimic_gym.spatial.camera import Intrinsics
from imimic_gym.spatial.truth import arm_poses, clip_intrinsics

__all__ = ["ImitateVideo3DEnv", "robot_directions"]

ROBOTS = ("so101",)


def robot_directions(model: mujoco.MjModel, data: mujoco.MjData, sites: np.ndarray
                     ) -> np.ndarray:
    """(3, 3) unit directions, robot base frame, of the robot's upper arm (shoulder ->
    elbow site), forearm (elbow -> wrist) and hand (wrist -> tool) at ``data``'s pose
    (`mujoco.mj_kinematics` is run first). ``sites``: the four site ids in that order."""
    mujoco.mj_kinematics(model, data)
    points = data.site_xpos[sites]
    return unit(np.diff(points, axis=0))


class ImitateVideo3DEnv(ImitateVideoEnv):
    """
    ## Description
    A person's arm moves in space in a video clip (the `spatial` scenarios: a reach toward
    the camera, a cup to the mouth, a sideways raise, a curl, a wave, or a mix; or a
    recorded video); an SO-101 arm in MuJoCo (six position servos, LeRobot's joint names,
    ranges and zero: `robots.so101`) should copy it. The same machinery as
    `ImitateVideo-v0` (clips, physics step, rendering, wrappers, controllers); what
    changes is the robot and what it is asked to do. The human arm and the robot differ,
    so the robot's target in each frame is the human arm's truth retargeted onto it
    (`retarget.DirectionRetargeter`, the named ``mapping``): its upper arm, forearm and
    hand pointing as the person's do, within its joint limits.

    ## Action Space
    `Box(-1, 1, (6,), float32)`, mapped linearly onto each joint's range: the position
    servos' target angles (rad), in LeRobot's order (shoulder_pan, shoulder_lift,
    elbow_flex, wrist_flex, wrist_roll, gripper). Clipped, NaN refused, as in v0.

    ## Observation Space
    `Dict`: `frame` `Box(0, 255, (H, W, 3), uint8)` RGB (grey depth for
    ``modality="depth"``), `qpos` `Box(-pi, pi, (6,), float64)` rad, `qvel`
    `Box(-200, 200, (6,), float64)` rad/s.

    ## Rewards
    `reward = reward_tracking + reward_ctrl`, both in `info`:
    - `reward_tracking = -tracking_weight * (e_upper^2 + e_forearm^2 + e_hand^2)`: the
      angles (rad) between the robot's upper arm, forearm and hand directions and those of
      the retargeted target, from both poses' forward kinematics (so it reads directions
      in space, and a robot exactly on target earns 0);
    - `reward_ctrl = -ctrl_cost_weight * sum_i a_i^2`.
    `info` also holds `upper_arm_direction_error_deg`, `forearm_direction_error_deg`,
    `hand_direction_error_deg`, `elbow_flexion_error_deg` (robot vs target),
    `joint_error_deg` (6,), `tracking_error_deg` (their RMS over the six joints),
    `target_angles` (6,) rad, and v0's `frame_index`, `occlusion`, `clip_seed`,
    `has_truth`.

    ## Starting State
    The robot at the first frame's target plus uniform noise of `reset_noise_scale` rad
    per joint, at rest; without truth, at LeRobot's zero (the middle of every range).

    ## Episode End
    As v0: `truncated=True` after the clip's last frame, never `terminated`.

    ## Arguments
    | Argument | Default | Meaning |
    |---|---|---|
    | `scenario` | `"spatial"` | a spatial scenario's name or a `Clip` with 3-D truth |
    | `robot` | `"so101"` | the robot that copies the arm |
    | `mapping` | `"mirror"` | how the person's arm maps onto the robot (`retarget.MAPPINGS`) |
    | `control` | `"position"` | the SO-101's servos take target angles only |
    | `modality` | `"rgb"` | `"rgb"` or `"depth"` frames in the observation |
    | `width` | `None` | frame width in pixels; `None` takes the clip's |
    | `height` | `None` | frame height in pixels; `None` takes the clip's |
    | `clip_seeds` | `(0,)` | seeds of the scenario's clips that resets draw from |
    | `n_frames` | `None` | clip length in frames; `None` takes the scenario's |
    | `tracking_weight` | `1.0` | weight of the squared direction errors, per rad^2 |
    | `ctrl_cost_weight` | `0.001` | weight of the squared action |
    | `reset_noise_scale` | `0.02` | start-pose noise, rad |
    | `render_mode` | `None` | `"rgb_array"`: `render()` returns video and robot side by side |
    | `clip` | `None` | a video file path or a `Clip`; overrides `scenario` (no truth) |
    | `render_height` | `None` | rows of `render()`'s picture if fewer than the clip's |

    ## Version History
    - v0: first version.
    """

    def __init__(
        self,
        scenario: str | Clip = "spatial",
        robot: str = "so101",
        mapping: str = "mirror",
        control: Control = "position",
        modality: str = "rgb",
        width: int | None = None,
        height: int | None = None,
        clip_seeds: Sequence[int] = (0,),
        n_frames: int | None = None,
        tracking_weight: float = 1.0,
        ctrl_cost_weight: float = 1e-3,
        reset_noise_scale: float = 0.02,
        render_mode: str | None = None,
        clip: str | Clip | None = None,
        render_height: int | None = None,
    ) -> None:
        if robot not in ROBOTS:
            raise ValueError(f"robot must be one of {ROBOTS}, got {robot!r}")
        if mapping not in MAPPINGS:
            raise ValueError(f"mapping must be one of {tuple(MAPPINGS)}, got {mapping!r}")
        if control != "position":
            raise ValueError(f"the SO-101's servos take target angles: control must be "
                             f"'position', got {control!r}")
        self.robot_spec = SO101Spec()
        self.mapping = mapping
        self.retarget = DirectionRetargeter(self.robot_spec, mapping=MAPPINGS[mapping])
        # The clip whose targets were last retargeted, its targets and their directions.
        self._retargeted: tuple[Clip, np.ndarray, np.ndarray] | None = None
        if isinstance(scenario, str) and clip is None:
            from imimic_gym.clips.scenarios import get_scenario

            if not get_scenario(scenario).spatial:
                raise ValueError(f"scenario {scenario!r} moves its arm in the image plane; "
                                 f"ImitateVideo3D-v0 takes a spatial one (spatial, "
                                 f"spatial-reach, ...) or ImitateVideo-v0 takes this one")
        super().__init__(
            scenario="default" if clip is not None else scenario, control=control,
            modality=modality, width=width, height=height, clip_seeds=clip_seeds,
            n_frames=n_frames, tracking_weight=tracking_weight,
            ctrl_cost_weight=ctrl_cost_weight, reset_noise_scale=reset_noise_scale,
            render_mode=render_mode, clip=clip, render_height=render_height)
        EzPickle.__init__(
            self, scenario, robot, mapping, control, modality, width, height, clip_seeds,
            n_frames, tracking_weight, ctrl_cost_weight, reset_noise_scale, render_mode,
            clip, render_height)
        self._sites = np.array([self.model.site(name).id for name in self.robot_spec.site_names])

    # The robot and its targets ---------------------------------------------------------
    def _robot_for_clip(self, clip: Clip, control: Control) -> SO101Spec:
        return self.robot_spec

    def _robot_for_spec(self, spec: ClipSpec, control: Control) -> SO101Spec:
        return self.robot_spec

    def _clip_targets(self, clip: Clip) -> np.ndarray | None:
        """(T, 6) rad: the clip's true arm retargeted onto the robot frame by frame (each
        frame continuing the last); None for a clip without 3-D truth."""
        if clip.truth is None or clip.truth.points3d is None:
            return None
        if self._retargeted is None or self._retargeted[0] is not clip:
            targets, previous = [], None
            for pose in arm_poses(clip):
                previous = self.retarget(pose, previous)
                targets.append(previous)
            q = np.array(targets)
            self._retargeted = (clip, q, self._target_directions(q))
        return self._retargeted[1]

    def _target_directions(self, targets: np.ndarray) -> np.ndarray:
        """(T, 3, 3): the upper arm, forearm and hand directions of each target pose."""
        data = mujoco.MjData(self.model)
        sites = np.array([self.model.site(name).id for name in self.robot_spec.site_names])
        out = np.empty((len(targets), 3, 3))
        for i, q in enumerate(targets):
            data.qpos[:] = q
            out[i] = robot_directions(self.model, data, sites)
        return out

    def intrinsics(self) -> Intrinsics:
        """The current clip's camera: its own for a rendered clip, a typical one for
        footage (`Intrinsics.guess`)."""
        if "intrinsics" in self.clip.meta:
            return clip_intrinsics(self.clip)
        return Intrinsics.guess(self.clip.width, self.clip.height)

    def estimator_context(self) -> EstimatorContext:
        """What an estimator may know (`ImitateVideoEnv.estimator_context`): the clip's
        frame rate and camera, a spatial clip, the robot's joints; the truth is the
        retargeted target."""
        return EstimatorContext(
            fps=float(self.clip.fps),
            link_parents=self.robot_spec.link_parents,
            joint_ranges=self.robot_spec.joint_ranges,
            reference_direction=-math.pi / 2,
            modality=self.modality,
            demonstrator="human",
            robot=self.model,
            truth=self._true_estimate if self._targets is not None else None,
            spatial=True,
            intrinsics=self.intrinsics(),
        )

    def _true_estimate(self) -> Estimate:
        """The retargeted target of the frame shown now (trust 1, torque 0), its rates by
        central differences."""
        assert self._targets is not None
        q, i, dt = self._targets, self.frame_index or 0, 1.0 / float(self.clip.fps)
        before, after = q[max(i - 1, 0)], q[min(i + 1, len(q) - 1)]
        omega = (after - before) / (dt * max(1, min(i + 1, len(q) - 1) - max(i - 1, 0)))
        alpha = (after - 2 * q[i] + before) / dt**2 if 0 < i < len(q) - 1 else np.zeros(6)
        return Estimate(angles=q[i], omega=omega, alpha=alpha, torque=np.zeros(6), trust=1.0)

    def _info(self, tracking: tuple[np.ndarray, np.ndarray] | None) -> dict[str, Any]:
        """v0's info, and with truth the robot's direction errors against its target."""
        info = super()._info(tracking)
        if tracking is None:
            return info
        assert self.frame_index is not None and self._retargeted is not None
        robot = robot_directions(self.model, self.data, self._sites)
        target = self._retargeted[2][self.frame_index]
        errors = direction_error_deg(robot, target)
        flexion = math.degrees(float(angle_between(robot[0], robot[1]))
                               - float(angle_between(target[0], target[1])))
        info["upper_arm_direction_error_deg"] = float(errors[0])
        info["forearm_direction_error_deg"] = float(errors[1])
        info["hand_direction_error_deg"] = float(errors[2])
        info["elbow_flexion_error_deg"] = abs(flexion)
        info["joint_error_deg"] = np.degrees(np.abs(tracking[1]))
        return info

    def _tracking_reward(self, tracking: tuple[np.ndarray, np.ndarray] | None,
                         info: dict[str, Any]) -> float:
        """``-tracking_weight * (e_upper^2 + e_forearm^2 + e_hand^2)``, the direction
        errors (rad) that `_info` put in ``info``; 0 without truth."""
        if tracking is None:
            return 0.0
        errors = np.radians([info["upper_arm_direction_error_deg"],
                             info["forearm_direction_error_deg"],
                             info["hand_direction_error_deg"]])
        return -self.tracking_weight * float(errors @ errors)
