"""ImitateVideo-v0: a MuJoCo robot arm follows a human arm that it sees only on video."""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any, cast

import cv2
import gymnasium as gym
import mujoco
import numpy as np
from gymnasium import spaces
from gymnasium.utils import EzPickle

from imimic_gym.clips.cache import load_clip
from imimic_gym.clips.scenarios import ClipSpec, get_scenario, robot_for_clip
from imimic_gym.clips.types import Clip, depth_to_frame
from imimic_gym.clips.video import FrameStream
from imimic_gym.envs.arguments import check_arguments, check_sources
from imimic_gym.estimators.types import Estimate, EstimatorContext
from imimic_gym.kinematics import wrap_angle
from imimic_gym.render import OffscreenRenderer
from imimic_gym.robots.planar import ArmSpec, Control
from imimic_gym.robots.spec import RobotSpec

__all__ = ["ImitateVideoEnv", "SimulationUnstableError", "imitate_env"]

# The physics step is the largest that divides a frame evenly and stays under this (s):
# 6 substeps of 5.6 ms per frame at 30 fps. It resolves the 12 Hz servo (omega dt = 0.42,
# damping implicit) as well as 2 ms steps do; `benchmarks/run.py speed --parts step` measures both.
MAX_PHYSICS_STEP = 0.0056
MAX_OBSERVED_SPEED = 200.0  # rad/s; the joint-velocity sensor saturates here
CLIPS_IN_MEMORY = 4
MIN_FPS, MAX_FPS = 1.0, 1000.0  # frames/s: one physics step a frame, 6 substeps at 30


_BAD_QACC = int(mujoco.mjtWarning.mjWARN_BADQACC)


class SimulationUnstableError(RuntimeError):
    """MuJoCo found a non-finite or huge joint acceleration during a step and reset the arm
    to its start pose: the arm's motors are too strong for its links at this step size."""


class ImitateVideoEnv(gym.Env, EzPickle):
    """
    ## Description
    A human arm moves in a video clip; a planar MuJoCo robot arm of the same number of
    links should move the same way at the same time ("controlling by showing", the
    i-Mimic paper). The agent sees the video frame and the robot's own joint state. One
    step is one video frame; the physics runs in between. Clips are rendered synthetic
    scenarios with ground truth (the paper's experiments 1-3 and more), a `Clip` object,
    or a recorded video (`clip="my.mp4"`, optionally with COCO-keypoints
    `annotations="my.json"` for ground truth; `imimic_gym.clips.video`).

    A clip without ground truth (a video without annotations, a live camera) runs too:
    `info["has_truth"]` is False, `reward_tracking` is 0, and `info` has no
    `target_angles` or `tracking_error_deg` (unknown: not zero, and not NaN, which would
    make equal episodes compare unequal). The robot is then built from the
    clip's `meta` (`reference_direction`, `joint_ranges`). The same holds for each frame
    of an annotated video that has no label (a frame the annotations leave out, or where
    the pose model gave no reading): `has_truth` False and `label_filled` True for that
    frame, no tracking reward, and no part of the metrics (`rollout.Trajectory`); the
    truth's angles there (`target_angles(i)`) are filled in between the labelled frames,
    something to steer by, not to score against. A video annotated with a person's arm
    (COCO keypoints or ``"pose"``) gets a robot with a human arm's joint ranges
    (`estimators.pose.human_joint_ranges`), as ``imimic mimic`` builds for a person; the
    truth JSON that ``imimic clip`` writes beside its mp4 gives the rendered clip's own
    robot and truth. A `Clip` whose frames are a
    `FrameStream` (`clips.video.stream_video`) is read forward only: one episode, no
    second reset, and `StreamEndedError` from `step` if the source ends early.

    ## Action Space
    `Box(-1, 1, (n_links,), float32)`, mapped linearly onto each actuator's range:
    target joint angle (rad) for `control="position"` (a servo, the paper's choice),
    target joint velocity (rad/s) for `"velocity"`, joint torque (N m) for `"torque"`.
    Actions outside [-1, 1] are clipped; a NaN or a wrong shape raises `ValueError` and
    leaves the simulation untouched.

    ## Observation Space
    `Dict`:
    - `frame`: `Box(0, 255, (height, width, 3), uint8)`, the current video frame, RGB; for
      `modality="depth"` the depth video as grey levels, near = bright.
    - `qpos`: `Box(-pi, pi, (n_links,), float64)`, robot joint angles, rad (every joint
      range lies inside).
    - `qvel`: `Box(-200, 200, (n_links,), float64)`, robot joint velocities, rad/s,
      saturating at +-200 like a real encoder's speed estimate.

    ## Rewards
    `reward = reward_tracking + reward_ctrl`, both in `info`:
    - `reward_tracking = -tracking_weight * sum_i wrap(q_i - q*_i)^2`, with `q*` the
      demonstrator's true joint angles (rad) in the frame that the observation shows;
    - `reward_ctrl = -ctrl_cost_weight * sum_i a_i^2`.
    `info` also holds `tracking_error_deg` (RMS over joints of the wrapped error, degrees),
    `frame_index`, `target_angles` (rad), `occlusion` (fraction of the moving links
    hidden), `clip_seed`, `has_truth` (False: no ground truth for this frame, tracking
    reward 0) and, for a clip with truth, `truth_source`: `"render"` (exact, also from
    `imimic clip`'s truth JSON), `"annotations"` (a COCO file) or `"pose"` (the pose
    model's pseudo-truth, `annotations="pose"`), and `label_filled` (True: this frame has
    no label; its truth is filled in and not scored).

    ## Starting State
    The robot starts at the demonstrator's first-frame angles plus uniform noise of
    `reset_noise_scale` rad per joint (clipped to the joint range), at rest; without
    ground truth, at the middle of the joint ranges plus that noise. The clip is
    drawn from `clip_seeds` with the env's random generator, or set by
    `reset(options={"clip_seed": s})`.

    ## Episode End
    One episode is one clip: after the clip's last frame, `truncated=True`. `terminated`
    is always False (the task has no end state). No `TimeLimit` is registered: the clip
    length is the limit.

    ## Arguments
    | Argument | Default | Meaning |
    |---|---|---|
    | `scenario` | `"default"` | scenario name (`imimic_gym.scenario_names()`) or a `Clip` |
    | `clip` | `None` | a video file path or a `Clip`; overrides `scenario` |
    | `annotations` | `None` | COCO JSON of the video `clip`, `"pose"`, or `imimic clip`'s JSON |
    | `n_links` | `None` | 1-3 moving links; `None` takes the scenario's |
    | `control` | `"position"` | `"position"`, `"velocity"` or `"torque"` actuation |
    | `modality` | `"rgb"` | `"rgb"` or `"depth"` frames in the observation |
    | `width` | `None` | frame width in pixels; `None` takes the clip's (320) |
    | `height` | `None` | frame height in pixels; `None` takes the clip's (240) |
    | `clip_seeds` | `(0,)` | seeds of the scenario's clips that resets draw from |
    | `n_frames` | `None` | clip length in frames; `None` takes the scenario's (150) |
    | `tracking_weight` | `1.0` | weight of the squared angle error, per rad^2 |
    | `ctrl_cost_weight` | `0.001` | weight of the squared action |
    | `reset_noise_scale` | `0.02` | start-pose noise, rad |
    | `render_mode` | `None` | `"rgb_array"`: `render()` returns video and robot side by side |
    | `render_height` | `None` | rows of `render()`'s picture if fewer than the clip's |

    ## Version History
    - v0: first version.
    """

    # Per instance, as gymnasium's Env declares it: each env sets its clip's render_fps.
    metadata: dict[str, Any] = {"render_modes": ["rgb_array"], "render_fps": 30}  # noqa: RUF012

    def __init__(
        self,
        scenario: str | Clip = "default",
        n_links: int | None = None,
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
        annotations: str | None = None,
        render_height: int | None = None,
    ) -> None:
        EzPickle.__init__(
            self, scenario, n_links, control, modality, width, height, clip_seeds,
            n_frames, tracking_weight, ctrl_cost_weight, reset_noise_scale, render_mode,
            clip, annotations, render_height,
        )
        check_arguments(control, modality, render_mode, self.metadata["render_modes"],
                        width=width, height=height, render_height=render_height,
                        n_frames=n_frames, n_links=n_links, tracking_weight=tracking_weight,
                        ctrl_cost_weight=ctrl_cost_weight,
                        reset_noise_scale=reset_noise_scale)
        check_sources(clip, annotations, clip_seeds)
        n_links = None if n_links is None else int(n_links)
        self.control, self.modality, self.render_mode = control, modality, render_mode
        self.render_height = render_height
        self.tracking_weight, self.ctrl_cost_weight = tracking_weight, ctrl_cost_weight
        self.reset_noise_scale = reset_noise_scale

        self._clips: dict[int, Clip] = {}
        self._fixed_clip: Clip | None = None
        self._spec: ClipSpec | None = None
        if clip is not None and not (isinstance(scenario, str) and scenario == "default"):
            given = repr(str(clip)) if isinstance(clip, (str, Path)) else "a Clip"
            raise ValueError(f"give the clip once: clip={given} or scenario={scenario!r}, "
                             f"not both")
        if annotations is not None and not isinstance(clip, (str, Path)):
            raise ValueError(f"annotations={annotations!r} belong to a video: give its path "
                             f"as clip=, got clip={clip!r}")
        if isinstance(clip, (str, Path)):
            from imimic_gym.clips.video_load import load_video

            clip = load_video(clip, annotations, n_links=n_links or 1, max_frames=n_frames)
        if clip is not None:
            scenario = clip
        if isinstance(scenario, Clip):
            if n_links is not None and n_links != scenario.n_links:
                raise ValueError(f"n_links={n_links} but the clip has {scenario.n_links} links")
            if not isinstance(scenario.frames, np.ndarray) and (width or height):
                raise ValueError("width/height resize a clip in memory; this clip streams "
                                 f"from {scenario.meta.get('path')}: leave them None")
            self._fixed_clip = scenario.resized(height, width)
            self.clip_seeds: tuple[int, ...] = (int(scenario.meta.get("seed", 0)),)
            arm = self._robot_for_clip(scenario, control)
        else:
            overrides = {k: v for k, v in (("n_links", n_links), ("width", width),
                         ("height", height), ("n_frames", n_frames)) if v is not None}
            self._spec = get_scenario(scenario, **overrides)
            self.clip_seeds = tuple(int(s) for s in clip_seeds)
            if not self.clip_seeds:
                raise ValueError("clip_seeds must name at least one seed, got an empty sequence")
            arm = self._robot_for_spec(self._spec, control)
        self.arm: RobotSpec = arm
        self.clip = self._load(self.clip_seeds[0])
        fps = self.clip.fps
        if len(self.clip) < 2:
            raise ValueError(f"clip {self.clip.meta.get('path', self.clip.meta)} has "
                             f"{len(self.clip)} frame; an episode needs at least 2 (one "
                             "step goes from a frame to the next)")
        if not MIN_FPS <= fps <= MAX_FPS:
            raise ValueError(f"clip {self.clip.meta.get('path', self.clip.meta)} plays at "
                             f"{fps:g} frames/s; ImitateVideo-v0 steps the physics once a "
                             f"frame and takes {MIN_FPS:g} to {MAX_FPS:g} (give the video's "
                             "real rate: stream_video/load_video(fps=...), --fps)")

        self.model = arm.build_model()
        self.n_substeps = max(1, math.ceil(1.0 / fps / MAX_PHYSICS_STEP))
        self.model.opt.timestep = 1.0 / fps / self.n_substeps
        self.data = mujoco.MjData(self.model)
        self._ctrl_low = self.model.actuator_ctrlrange[:, 0].copy()
        self._ctrl_high = self.model.actuator_ctrlrange[:, 1].copy()
        self._joint_low = self.model.jnt_range[:, 0].copy()
        self._joint_high = self.model.jnt_range[:, 1].copy()
        self.metadata = {**self.metadata, "render_fps": fps}

        n = arm.n_joints
        self._targets = self._clip_targets(self.clip)
        h, w = self.clip.height, self.clip.width
        self.action_space = spaces.Box(-1.0, 1.0, shape=(n,), dtype=np.float32)
        self.observation_space = spaces.Dict({
            "frame": spaces.Box(0, 255, shape=(h, w, 3), dtype=np.uint8),
            "qpos": spaces.Box(-np.pi, np.pi, shape=(n,), dtype=np.float64),
            "qvel": spaces.Box(
                -MAX_OBSERVED_SPEED, MAX_OBSERVED_SPEED, shape=(n,), dtype=np.float64
            ),
        })
        self.frame_index: int | None = None
        self._last_frame = len(self.clip) - 1
        self._frames = self._observed_frames(self.clip)
        self._renderer: OffscreenRenderer | None = None
        self._robot_view_started: np.ndarray | None = None  # robot pose of prepare_render's view
        self._upcoming: tuple[int, np.ndarray] | None = None  # upcoming_frame's (index, frame)

    # The robot and its targets: what ImitateVideo3D-v0 replaces -----------------------
    def _robot_for_clip(self, clip: Clip, control: Control) -> RobotSpec:
        """The robot for a given clip (a recorded video): `robot_for_clip`."""
        return robot_for_clip(clip, control)

    def _robot_for_spec(self, spec: ClipSpec, control: Control) -> RobotSpec:
        """The robot for a scenario's clips: the demonstrator's arm (`ClipSpec.robot_arm`)."""
        return spec.robot_arm(control)

    def _clip_targets(self, clip: Clip) -> np.ndarray | None:
        """(T, n) rad: the joint angles the robot should have in each frame of ``clip``
        (here the truth's own), None without truth."""
        return clip.truth.angles if clip.truth is not None else None

    # Clips ---------------------------------------------------------------------------
    def _load(self, seed: int) -> Clip:
        """The clip of ``seed``, from memory, else the disk cache, else rendered. Memory
        keeps the last ``CLIPS_IN_MEMORY`` (a 150-frame clip is ~58 MB)."""
        if self._fixed_clip is not None:
            return self._fixed_clip
        if seed not in self._clips:
            assert self._spec is not None
            if len(self._clips) >= CLIPS_IN_MEMORY:
                self._clips.pop(next(iter(self._clips)))
            self._clips[seed] = load_clip(self._spec.replace(seed=seed))
        return self._clips[seed]

    def _observed_frames(self, clip: Clip) -> np.ndarray:
        if self.modality == "rgb":
            return clip.frames
        if clip.depth is None:
            raise ValueError(f"modality='depth' needs a clip with depth; clip {clip.meta} has none")
        return depth_to_frame(clip.depth)

    # Helpers -------------------------------------------------------------------------
    def action_to_command(self, action: np.ndarray) -> np.ndarray:
        """Actuator command (rad, rad/s or N m) for a normalised action in [-1, 1]."""
        return self._command(np.clip(np.asarray(action, dtype=np.float64), -1.0, 1.0))

    def _command(self, a: np.ndarray) -> np.ndarray:
        """`action_to_command` of an action already in [-1, 1]."""
        return self._ctrl_low + (a + 1.0) * 0.5 * (self._ctrl_high - self._ctrl_low)

    def command_to_action(self, command: np.ndarray) -> np.ndarray:
        """The normalised action (float32, clipped to [-1, 1]) for an actuator command."""
        a = 2.0 * (np.asarray(command) - self._ctrl_low) / (self._ctrl_high - self._ctrl_low) - 1.0
        return np.clip(a, -1.0, 1.0).astype(np.float32)

    def target_angles(self, frame_index: int) -> np.ndarray:
        """The demonstrator's true joint angles (rad) at ``frame_index`` (clamped to the
        clip); on a frame without a label, filled in between the labelled ones. Raises
        ValueError for a clip without truth."""
        if self._targets is None:
            raise ValueError(f"clip {self.clip.meta.get('path', self.clip.meta)} has no ground "
                             "truth: no target angles (load it with annotations)")
        i = min(max(frame_index, 0), len(self.clip) - 1)
        return self._targets[i].copy()

    def estimator_context(self) -> EstimatorContext:
        """What an estimator may know about the current clip and this robot: the seam
        between env and estimators (`estimators.registry`). Wrappers reach it through
        ``env.get_wrapper_attr("estimator_context")()``."""
        return EstimatorContext(
            fps=float(self.clip.fps),
            link_parents=tuple(self.arm.link_parents),
            joint_ranges=tuple((float(lo), float(hi)) for lo, hi in self.arm.joint_ranges),
            reference_direction=float(self.clip.meta.get(
                "reference_direction", cast(ArmSpec, self.arm).reference_direction)),
            modality=self.modality,
            demonstrator=str(self.clip.meta.get("demonstrator", "human")),
            robot=self.model,
            truth=self._true_estimate if self.clip.truth is not None else None,
        )

    def _true_estimate(self) -> Estimate:
        """The truth of the frame shown now as an `Estimate` (trust 1, torque 0)."""
        truth, i = self.clip.truth, self.frame_index or 0
        assert truth is not None
        return Estimate(angles=truth.angles[i], omega=truth.angular_velocity[i],
                        alpha=truth.angular_acceleration[i],
                        torque=np.zeros(truth.angles.shape[1]), trust=1.0)

    def _observed_frame(self, index: int) -> np.ndarray:
        """Frame ``index`` in an array of its own (a stream's comes copied off this thread)."""
        frames = self._frames
        return (frames.fresh(index) if isinstance(frames, FrameStream)
                else frames[index].copy())

    def upcoming_frame(self, wait: bool = False) -> np.ndarray | None:
        """The (H, W, 3) uint8 frame that the next `step` will observe: the very array
        that its observation's ``frame`` will be, which nothing else holds (read it, do not
        change it). None where it is not known ahead: after the clip's last frame, before
        `reset`, or where the stream ends or fails there (the step then says so). A live
        source's (a camera's) next frame is read only with ``wait`` (it waits for the
        source to deliver it; a caller asks once the step's command is out, so that the
        wait delays nothing the robot needs); without, None there."""
        if self.frame_index is None or self.frame_index >= self._last_frame:
            return None
        index = self.frame_index + 1
        if self._upcoming is not None and self._upcoming[0] == index:
            return self._upcoming[1]
        if isinstance(self._frames, FrameStream) and self._frames.reader.live and not wait:
            return None
        try:
            frame = self._observed_frame(index)
        except Exception:  # the stream's end or error, which the step's reading raises
            return None
        self._upcoming = (index, frame)
        return frame

    def _obs(self) -> dict[str, np.ndarray]:
        assert self.frame_index is not None
        upcoming, self._upcoming = self._upcoming, None
        return {
            "frame": (upcoming[1] if upcoming is not None and upcoming[0] == self.frame_index
                      else self._observed_frame(self.frame_index)),
            "qpos": self.data.qpos.copy(),
            "qvel": self.data.qvel.clip(-MAX_OBSERVED_SPEED, MAX_OBSERVED_SPEED),
        }

    def _tracking(self) -> tuple[np.ndarray, np.ndarray] | None:
        """The demonstrator's angles in the current frame and the robot's wrapped error;
        None without truth for this frame."""
        assert self.frame_index is not None
        if self._targets is None or not (self.clip.truth is None
                                         or self.clip.truth.has_label(self.frame_index)):
            return None
        target = self._targets[self.frame_index]
        return target, wrap_angle(self.data.qpos - target)

    def _info(self, tracking: tuple[np.ndarray, np.ndarray] | None) -> dict[str, Any]:
        truth = self.clip.truth
        info: dict[str, Any] = {
            "frame_index": self.frame_index,
            "occlusion": float(truth.occlusion[self.frame_index]) if truth is not None else 0.0,
            "clip_seed": int(self.clip.meta.get("seed", 0)),
            "has_truth": tracking is not None,
        }
        if truth is not None:  # "render", or "annotations"/"pose" for recorded video
            info["truth_source"] = self.clip.meta.get("truth_source", "render")
            info["label_filled"] = tracking is None
        if tracking is not None:
            target, error = tracking
            info["tracking_error_deg"] = math.degrees(math.sqrt(float(error @ error) / error.size))
            info["target_angles"] = target.copy()
        return info

    # Gymnasium API -------------------------------------------------------------------
    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        super().reset(seed=seed)
        options = options or {}
        if "clip_seed" in options:
            clip_seed = int(options["clip_seed"])
        else:
            clip_seed = self.clip_seeds[int(self.np_random.integers(len(self.clip_seeds)))]
        clip = self._load(clip_seed)
        if clip is not self.clip:
            self.clip, self._frames = clip, self._observed_frames(clip)
            self._targets = self._clip_targets(clip)
        mujoco.mj_resetData(self.model, self.data)
        start = self._targets[0] if self._targets is not None else np.mean(
            [self._joint_low, self._joint_high], axis=0)
        scale = self.reset_noise_scale
        noise = self.np_random.uniform(-scale, scale, size=start.shape)
        self.data.qpos[:] = np.clip(start + noise, self._joint_low, self._joint_high)
        if self.control == "position":
            self.data.ctrl[:] = self.data.qpos  # the servo holds the start pose
        mujoco.mj_forward(self.model, self.data)
        self.frame_index, self._last_frame = 0, len(self.clip) - 1
        self._upcoming = None
        return self._obs(), self._info(self._tracking())

    def step(
        self, action: np.ndarray
    ) -> tuple[dict[str, np.ndarray], float, bool, bool, dict[str, Any]]:
        if self.frame_index is None:
            raise RuntimeError("call reset() before step()")
        if self.frame_index >= self._last_frame:
            raise RuntimeError("the clip has ended (truncated=True was returned); call reset()")
        a = np.asarray(action, dtype=np.float64)
        if a.shape != self.action_space.shape:
            raise ValueError(
                f"action must have shape {self.action_space.shape}, got {a.shape}: {action!r}"
            )
        if not math.isfinite(sum(a.tolist())):  # NaN and +-inf survive a sum; fast for n <= 3
            raise ValueError(f"action must be finite numbers in [-1, 1], got {a.tolist()}")
        a = a.clip(-1.0, 1.0)
        self.data.ctrl[:] = self._command(a)
        unstable = self.data.warning[_BAD_QACC].number
        mujoco.mj_step(self.model, self.data, nstep=self.n_substeps)
        if self.data.warning[_BAD_QACC].number != unstable:
            # MuJoCo has already put the arm back at its start pose: say so, rather than
            # carry on as if the arm had jumped there.
            raise SimulationUnstableError(
                f"the physics went unstable in frame {self.frame_index + 1} under action "
                f"{a.tolist()} ({self.arm.control} control, command range "
                f"{self._ctrl_high.tolist()}, {1000 * self.model.opt.timestep:.2f} ms steps): "
                "MuJoCo found a non-finite or huge joint acceleration and reset the arm to "
                "its start pose; the motors are too strong for the links. Call reset()."
            )
        self.frame_index += 1

        tracking = self._tracking()
        info = self._info(tracking)
        reward_tracking = self._tracking_reward(tracking, info)
        reward_ctrl = -self.ctrl_cost_weight * float(a @ a)
        info["reward_tracking"], info["reward_ctrl"] = reward_tracking, reward_ctrl
        truncated = self.frame_index == self._last_frame
        return self._obs(), reward_tracking + reward_ctrl, False, truncated, info

    def _tracking_reward(self, tracking: tuple[np.ndarray, np.ndarray] | None,
                         info: dict[str, Any]) -> float:
        """``-tracking_weight * sum_i wrap(q_i - q*_i)^2``; 0 without truth."""
        if tracking is None:
            return 0.0
        return -self.tracking_weight * float(tracking[1] @ tracking[1])

    def render(self) -> np.ndarray | None:
        """(H, 2W, 3) uint8: the video frame (left) beside the robot (right), same size;
        H = ``render_height`` where that is fewer rows than the clip's (the frame area-
        averaged down, the robot drawn at that size: a 1080p preview costs more to draw
        and encode than the footage costs to read). A new array each call."""
        if self.render_mode is None:
            gym.logger.warn("render() called without render_mode='rgb_array'; returning None")
            return None
        frame = self._frames[self.frame_index or 0]
        height, width = self._render_size()
        # Both halves are written straight into the picture: no half is copied twice.
        picture = np.empty((height, 2 * width, 3), dtype=np.uint8)
        if height < frame.shape[0]:
            cv2.resize(frame, (width, height), dst=picture[:, :width],
                       interpolation=cv2.INTER_AREA)
        else:
            picture[:, :width] = frame
        renderer = self._robot_renderer()
        if self._robot_view_started is None or not np.array_equal(self._robot_view_started,
                                                                  self._robot_pose()):
            renderer.start(self.data, self.model.camera("robot").id)
        self._robot_view_started = None
        renderer.finish(out=picture[:, width:])
        return picture

    def prepare_render(self) -> None:
        """Start drawing the robot view of the current state and return at once: the GL
        driver draws it meanwhile (Mesa's software renderer on a thread of its own, while
        the caller estimates the frame, say), and the next `render` only reads it back.
        A `render` after the robot moved draws the view afresh. Nothing without
        ``render_mode``."""
        if self.render_mode is None:
            return
        self._robot_renderer().start(self.data, self.model.camera("robot").id)
        self._robot_view_started = self._robot_pose()

    def _render_size(self) -> tuple[int, int]:
        """(rows, columns) of each half of `render`'s picture."""
        height, width = self._frames.shape[1:3]
        if self.render_height is not None and self.render_height < height:
            return self.render_height, max(1, round(width * self.render_height / height))
        return height, width

    def _robot_renderer(self) -> OffscreenRenderer:
        if self._renderer is None:
            self._renderer = OffscreenRenderer(self.model, *self._render_size())
        return self._renderer

    def _robot_pose(self) -> np.ndarray:
        """Every body's position and orientation (world frame): what the robot view shows."""
        return np.concatenate([self.data.xpos.ravel(), self.data.xquat.ravel()])

    def close(self) -> None:
        self._robot_view_started = None
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None


def imitate_env(env: gym.Env) -> ImitateVideoEnv:
    """The `ImitateVideoEnv` under ``env``'s wrappers (controllers read its robot and clip
    through it). TypeError if ``env`` is not one."""
    inner = env.unwrapped
    if not isinstance(inner, ImitateVideoEnv):
        raise TypeError(f"expected an ImitateVideo-v0 env (wrapped or not), got "
                        f"{type(inner).__name__}")
    return inner
