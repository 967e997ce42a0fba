"""A learned tracker: a stable-baselines3 policy that corrects a scripted controller.

The policy sees only what a real deployment has: the robot's joint state, the
estimator's output (angles, omega, alpha, trust, predicted), how the estimate changed
since the last frame, and the time since the episode began. It never sees the truth.
Its action is a residual on a scripted controller's action (`PositionController`'s servo
target, or `VelocityController`'s velocity command), so an untrained policy (action 0)
is exactly the scripted controller, and training only has to learn
what the estimate gets wrong: that DON knows nothing until the arm moves (its first
guess is the middle of the joint range while the robot starts at the true pose), that
the estimate lags, and when a jumpy estimate is better not followed.

``python training/train_tracker.py`` trains it; `LearnedController` loads the shipped
policy for its env (``checkpoints/tracker.pt`` and its ``tracker.json`` on
ImitateVideo-v0, ``checkpoints/tracker3d.pt`` and ``tracker3d.json`` on ImitateVideo3D-v0,
the SO-101) as a controller with the scripted controllers' interface. A policy's residual
acts on the joints its metadata names (``residual_joints``; none recorded: every joint);
the others get the scripted controller's action unchanged.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from imimic_gym.checkpoints import SHIPPED_CHECKPOINTS, CheckpointError, verify_checkpoint
from imimic_gym.controllers.scripted import SCRIPTED_CONTROLLERS
from imimic_gym.envs.imitate_video import imitate_env
from imimic_gym.envs.imitate_video_3d import ImitateVideo3DEnv
from imimic_gym.estimators.types import estimate_fields
from imimic_gym.kinematics import wrap_angle

__all__ = ["DEFAULT_CHECKPOINT", "DEFAULT_CHECKPOINTS", "LearnedController", "ResidualTracking",
           "TrackerFeatures", "checkpoint_control", "env_id", "load_policy",
           "residual_joint_indices"]

DEFAULT_CHECKPOINT = SHIPPED_CHECKPOINTS / "tracker.pt"
# The shipped policy for each env id (a policy drives the arm it was trained on).
DEFAULT_CHECKPOINTS = {"ImitateVideo-v0": DEFAULT_CHECKPOINT,
                       "ImitateVideo3D-v0": SHIPPED_CHECKPOINTS / "tracker3d.pt"}
FEATURES_VERSION = 2
KNOWN_FEATURES_VERSIONS = (1, 2)
TIME_HORIZON_S = 2.0  # the time feature saturates here: only the start needs a clock
OMEGA_SCALE, ALPHA_SCALE = 2 * np.pi, 100.0  # rad/s and rad/s^2 that map to 1
ERROR_SCALE = 0.1  # rad of estimate-minus-robot that maps to 1 (version 2)


class TrackerFeatures:
    """The policy's observation, computed from the wrapped env's observation.

    ((8 + history + rate_history) n + 3 + rate_history,) float32 in [-5, 5], angles
    normalised to the joint range (-1 and 1 at its ends): qpos, qvel / 2 pi, estimated
    angles, omega / 2 pi, alpha / 100, the estimate minus qpos, the estimate's change
    since the last frame, the estimate's total change since the episode began (zero
    until DON has seen the arm move), trust, predicted, min(t, 2 s) / 2 s, its change
    since each of the ``history`` frames before the last (how a jump or a stall looks
    over a few frames), then, for each of the ``rate_history`` frames before this one,
    the estimated omega / 2 pi and the trust then. Stateful: call ``reset()`` with the
    episode.

    ``version`` 2 (the default) rescales the small signals that the servo's corrections
    depend on, so that they reach the network's first layer at the size of the others:
    the estimate minus qpos is divided by 0.1 rad (clipped at 0.5 rad) and the changes
    since the last and the ``history`` earlier frames become mean rates, divided by
    2 pi rad/s like omega (version 1, the first shipped policy's, divides them all by
    the joint's half range, so a servo's one-degree error is a 0.02 input).

    Why the rate history: DON's omega is a difference of two noisy angles (on the servo
    clips its RMS error is about 26 deg/s against 7 deg/s for the angles' own central
    difference), so one frame of it leads the angle badly; averaged over a dozen frames
    it predicts the next frame's angle about twice as well (a least-squares fit on
    training clips), and a policy can only learn that average if it sees the frames.
    """

    def __init__(self, env: gym.Env, history: int = 0, rate_history: int = 0,
                 version: int = FEATURES_VERSION) -> None:
        if version not in KNOWN_FEATURES_VERSIONS:
            raise ValueError(f"features version must be one of {KNOWN_FEATURES_VERSIONS}, "
                             f"got {version!r}")
        self.version = version

        inner = imitate_env(env)
        low, high = (np.asarray(r) for r in zip(*inner.arm.joint_ranges, strict=True))
        self.mid, self.half = (low + high) / 2, (high - low) / 2
        self.n = inner.arm.n_joints
        self.dt = 1.0 / float(inner.clip.fps)
        self.fields = estimate_fields(self.n)
        self.history, self.rate_history = history, rate_history
        self.size = (8 + history + rate_history) * self.n + 3 + rate_history
        self.space = spaces.Box(-5.0, 5.0, shape=(self.size,), dtype=np.float32)
        self.reset()

    def reset(self) -> None:
        self.first: np.ndarray | None = None
        self.previous: np.ndarray | None = None
        self.past: list[np.ndarray] = []
        self.past_rates: list[np.ndarray] = []
        self.steps = 0

    def __call__(self, obs: dict[str, Any]) -> np.ndarray:
        estimate = np.asarray(obs["estimate"], dtype=np.float64)
        angles = estimate[self.fields["angles"]]
        if self.first is None or self.previous is None:  # set together
            self.first = self.previous = angles
            self.past = [angles] * self.history
        rate = np.concatenate([estimate[self.fields["omega"]] / OMEGA_SCALE,
                               estimate[self.fields["trust"]]])
        if not self.past_rates:
            self.past_rates = [rate] * self.rate_history
        qpos = np.asarray(obs["qpos"], dtype=np.float64)
        if self.version == 1:
            error_scale = self.half
            change_scales = [self.half] * (self.history + 1)
        else:
            error_scale = np.full(self.n, ERROR_SCALE)
            change_scales = [OMEGA_SCALE * self.dt * frames
                             for frames in range(1, self.history + 2)]
        vector = np.concatenate([
            (qpos - self.mid) / self.half,
            np.asarray(obs["qvel"]) / OMEGA_SCALE,
            (angles - self.mid) / self.half,
            estimate[self.fields["omega"]] / OMEGA_SCALE,
            estimate[self.fields["alpha"]] / ALPHA_SCALE,
            wrap_angle(angles - qpos) / error_scale,
            wrap_angle(angles - self.previous) / change_scales[0],
            wrap_angle(angles - self.first) / self.half,
            estimate[self.fields["trust"]],
            estimate[self.fields["predicted"]],
            [min(self.steps * self.dt, TIME_HORIZON_S) / TIME_HORIZON_S],
            *(wrap_angle(angles - past) / scale
              for past, scale in zip(self.past, change_scales[1:], strict=True)),
            *self.past_rates,
        ])
        if self.history:
            self.past = [self.previous, *self.past[:-1]]
        if self.rate_history:
            self.past_rates = [rate, *self.past_rates[:-1]]
        self.previous = angles
        self.steps += 1
        return np.clip(vector, -5.0, 5.0).astype(np.float32)


def residual_joint_indices(env: gym.Env, joints: tuple[str, ...] | None) -> np.ndarray:
    """(k,) int: where the named joints sit in ``env``'s action (the arm's joint order);
    ``joints`` None: every joint. Raises ValueError naming a joint the arm lacks, a repeat,
    or an empty list."""
    names = tuple(imitate_env(env).arm.joint_names)
    if joints is None:
        return np.arange(len(names))
    unknown = [name for name in joints if name not in names]
    if unknown or not joints or len(set(joints)) != len(joints):
        raise ValueError(f"residual joints must be distinct joints of this arm {names}, got "
                         f"{list(joints)}" + (f" (unknown: {unknown})" if unknown else ""))
    return np.array([names.index(name) for name in joints])


class _Residual:
    """The scripted controller's action (for the env's control mode) plus ``scale`` times
    the policy's action on the ``joints`` it acts on (None: every joint); the other joints
    get the scripted controller's action unchanged (bit for bit)."""

    def __init__(self, env: gym.Env, scale: float, history: int = 0, rate_history: int = 0,
                 version: int = FEATURES_VERSION,
                 joints: tuple[str, ...] | None = None) -> None:
        control = imitate_env(env).control
        if control not in ("position", "velocity"):
            raise ValueError("the learned tracker corrects the position or velocity "
                             f"controller; this env has control={control!r}")
        self.base = SCRIPTED_CONTROLLERS[control](env)
        self.features, self.scale = TrackerFeatures(env, history, rate_history,
                                                      version), scale
        self.joints = residual_joint_indices(env, joints)

    def reset(self) -> None:
        self.base.reset()
        self.features.reset()

    def action(self, obs: dict[str, Any], residual: np.ndarray) -> np.ndarray:
        action = np.asarray(self.base(obs), dtype=np.float32).copy()
        corrected = action[self.joints].astype(np.float64) + self.scale * np.asarray(residual)
        action[self.joints] = np.clip(corrected, -1.0, 1.0)
        return action


class ResidualTracking(gym.Wrapper, gym.utils.RecordConstructorArgs):
    """Training view of an estimator-wrapped ImitateVideo env (``control="position"`` or
    ``"velocity"``): observations are `TrackerFeatures`, actions (k,) in [-1, 1] are
    residuals added (times ``residual_scale``) to the scripted controller's normalised
    action for that control mode (which holds the start pose until the estimator's first
    reading) on the k ``residual_joints`` (the arm's joint names, in the action's order;
    None: every joint); the other joints get the scripted controller's action unchanged.
    The reward is the env's
    times ``reward_scale`` (its truth stays in the reward and in ``info``, never in
    observations).
    """

    def __init__(self, env: gym.Env, residual_scale: float = 0.5, reward_scale: float = 1.0,
                 history: int = 0, rate_history: int = 0,
                 residual_joints: tuple[str, ...] | None = None) -> None:
        gym.utils.RecordConstructorArgs.__init__(self, residual_scale=residual_scale,
                                                 reward_scale=reward_scale,
                                                 history=history, rate_history=rate_history,
                                                 residual_joints=residual_joints)
        gym.Wrapper.__init__(self, env)
        if not isinstance(env.observation_space, spaces.Dict) or (
                "estimate" not in env.observation_space.spaces):
            raise TypeError("ResidualTracking needs an estimator wrapper's obs['estimate'] "
                            f"(e.g. DONObservation), got {env.observation_space}")
        self.residual = _Residual(env, residual_scale, history, rate_history,
                                  joints=residual_joints)
        self.reward_scale = reward_scale
        self.observation_space = self.residual.features.space
        self.action_space = spaces.Box(-1.0, 1.0, shape=self.residual.joints.shape,
                                       dtype=np.float32)
        self._obs: dict[str, Any] | None = None

    def reset(self, **kwargs: Any) -> tuple[np.ndarray, dict[str, Any]]:
        self._obs, info = self.env.reset(**kwargs)
        self.residual.reset()
        return self.residual.features(self._obs), info

    def step(self, action: np.ndarray) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        assert self._obs is not None, "call reset() before step()"
        a = self.residual.action(self._obs, action)
        self._obs, reward, terminated, truncated, info = self.env.step(a)
        features = self.residual.features(self._obs)
        return features, self.reward_scale * float(reward), terminated, truncated, info


def env_id(env: gym.Env) -> str:
    """The id of the ImitateVideo env under ``env``'s wrappers: ``"ImitateVideo3D-v0"`` for
    the SO-101 copying an arm in space, else ``"ImitateVideo-v0"``."""
    inner = imitate_env(env)
    return "ImitateVideo3D-v0" if isinstance(inner, ImitateVideo3DEnv) else "ImitateVideo-v0"


def checkpoint_control(checkpoint: str | Path = DEFAULT_CHECKPOINT) -> str:
    """The control mode a checkpoint drives (its metadata's ``control``); "position" when
    there is no checkpoint yet (`LearnedController` then says what is missing)."""
    meta_path = Path(checkpoint).with_suffix(".json")
    if not meta_path.is_file():
        return "position"
    try:
        return str(json.loads(meta_path.read_text())["control"])
    except (json.JSONDecodeError, KeyError, TypeError) as err:
        raise CheckpointError(f"tracker metadata {meta_path} is not a complete JSON record "
                              f"of a trained tracker ({type(err).__name__}: {err})") from err


def load_policy(path: str | Path, metadata: dict[str, Any]) -> Any:
    """An SB3 policy rebuilt from its metadata and the weights at ``path`` (a
    ``state_dict`` saved by ``training/train_tracker.py``, loaded with
    ``weights_only=True``: no pickled code runs)."""
    import pickle
    import zipfile

    import torch
    from stable_baselines3.common.utils import ConstantSchedule

    algo = metadata["algorithm"]
    size, n = metadata["observation_size"], metadata["action_size"]
    obs_space = spaces.Box(-5.0, 5.0, shape=(size,), dtype=np.float32)
    act_space = spaces.Box(-1.0, 1.0, shape=(n,), dtype=np.float32)
    policy_class: type[SACPolicy | ActorCriticPolicy]
    if algo == "sac":
        from stable_baselines3.sac.policies import SACPolicy

        policy_class = SACPolicy
    elif algo == "ppo":
        from stable_baselines3.common.policies import ActorCriticPolicy

        policy_class = ActorCriticPolicy
    else:
        raise ValueError(f"{path}: metadata 'algorithm' must be 'sac' or 'ppo', got {algo!r}")
    policy = policy_class(obs_space, act_space, ConstantSchedule(0.0),
                          net_arch=list(metadata["net_arch"]))
    try:
        policy.load_state_dict(torch.load(path, map_location="cpu", weights_only=True))
    except (RuntimeError, pickle.UnpicklingError, EOFError, zipfile.BadZipFile,
            ValueError) as err:
        first = " ".join(str(err).strip().splitlines()[:3])
        raise CheckpointError(f"tracker checkpoint {path} is not a {algo.upper()} policy "
                              f"state_dict matching its metadata (corrupt, truncated or "
                              f"another architecture?): {first}") from err
    policy.set_training_mode(False)
    return policy


class LearnedController:
    """The trained residual policy as a controller: ``reset()``, ``__call__(obs) ->
    action``, for an estimator-wrapped env with the control mode it was trained on
    (``control`` in its metadata).

    Args:
        env: the wrapped env (for the joint ranges, fps and the servo's action scale).
        checkpoint: the policy weights (``.pt``); its metadata is the ``.json`` beside it.
            None: the shipped one for the env (`DEFAULT_CHECKPOINTS`). A policy trained on
            the other env (its metadata's ``env``; none recorded: ImitateVideo-v0) is
            refused. Its residual acts on the joints its metadata's ``residual_joints``
            names (none recorded, as in the checkpoints from before it: every joint, the
            meaning they were trained with); the others follow the scripted controller.
    """

    def __init__(self, env: gym.Env, checkpoint: str | Path | None = None) -> None:
        checkpoint = Path(checkpoint or DEFAULT_CHECKPOINTS[env_id(env)])
        meta_path = checkpoint.with_suffix(".json")
        if not checkpoint.is_file() or not meta_path.is_file():
            raise FileNotFoundError(f"learned tracker needs {checkpoint} and {meta_path}; "
                                    "train one with python training/train_tracker.py")
        try:
            self.metadata = json.loads(meta_path.read_text())
            control = self.metadata["control"]
        except (json.JSONDecodeError, KeyError, TypeError) as err:
            raise CheckpointError(f"tracker metadata {meta_path} is not a complete JSON "
                                  f"record of a trained tracker ({type(err).__name__}: "
                                  f"{err})") from err
        trained_on, here = self.metadata.get("env", "ImitateVideo-v0"), env_id(env)
        if trained_on != here:
            raise ValueError(f"tracker checkpoint {checkpoint} was trained on {trained_on}; "
                             f"this env is {here} (another robot: the shipped policy for it "
                             f"is {DEFAULT_CHECKPOINTS[here].name})")
        verify_checkpoint(checkpoint, self.metadata)
        version = self.metadata.get("features_version")
        if version not in KNOWN_FEATURES_VERSIONS:
            raise ValueError(f"{meta_path}: features_version {version!r}, this code computes "
                             f"versions {KNOWN_FEATURES_VERSIONS}; retrain the tracker")
        if imitate_env(env).control != control:
            raise ValueError(f"LearnedController drives control={control!r} actuation; this "
                             f"env has control={imitate_env(env).control!r}")
        joints = self.metadata.get("residual_joints")
        try:
            self.residual = _Residual(env, float(self.metadata["residual_scale"]),
                                      int(self.metadata.get("history_frames", 0)),
                                      int(self.metadata.get("rate_history_frames", 0)), version,
                                      None if joints is None else tuple(joints))
        except ValueError as err:
            raise ValueError(f"{meta_path}: {err}") from err
        if self.metadata["observation_size"] != self.residual.features.size:
            raise ValueError(f"{meta_path}: a policy for {self.metadata['observation_size']} "
                             f"features, this env gives {self.residual.features.size}")
        if self.metadata["action_size"] != len(self.residual.joints):
            raise CheckpointError(f"{meta_path}: action_size {self.metadata['action_size']}, "
                                  f"but its residual acts on {len(self.residual.joints)} "
                                  f"joints ({'every joint' if joints is None else joints})")
        self.policy = load_policy(checkpoint, self.metadata)

    def reset(self) -> None:
        self.residual.reset()

    def __call__(self, obs: dict[str, Any]) -> np.ndarray:
        residual, _ = self.policy.predict(self.residual.features(obs), deterministic=True)
        return self.residual.action(obs, residual)
