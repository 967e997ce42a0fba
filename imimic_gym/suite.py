"""The tracking evaluation suite: scenarios x estimators x controllers x held-out seeds.

Every run is a plain Gymnasium loop, ``obs, info = env.reset(seed=s)`` then
``env.step(controller(obs))`` to the clip's end (`rollout.run_episode`), or the same loop
over ``gym.make_vec`` sub-envs when ``num_envs > 1``; both give the same numbers. The
estimators are those of `estimators.registry`; the controllers are a registry here:
adding one is one line.
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from typing import Any, cast

import gymnasium as gym
import numpy as np
from tqdm import tqdm

from imimic_gym.clips.cache import load_clip
from imimic_gym.clips.scenarios import get_scenario
from imimic_gym.estimators.registry import ESTIMATORS
from imimic_gym.rollout import Step, Trajectory, TrajectoryLog, run_episode

__all__ = [
    "CONTROLLERS", "FIRST_HELD_OUT_SEED", "METRICS", "RunConfig", "estimator_wrapper",
    "iter_suite", "run_config", "run_suite", "summarise", "summarise_rows",
]

FIRST_HELD_OUT_SEED = 1000  # training and tests use clip seeds below this
METRICS = ("rmse_deg", "max_error_deg", "lag_frames", "jerk_deg_s3", "recovery_s",
           "mean_trust")


def estimator_wrapper(name: str, params: tuple[tuple[str, Any], ...] = ()
                      ) -> Callable[[gym.Env], gym.Wrapper]:
    """A picklable wrapper factory (``gym.make_vec(wrappers=[...])``) that adds the
    registered estimator ``name``'s ``obs["estimate"]`` (built with ``params``, (name,
    value) pairs) and drops the frame."""
    return functools.partial(_wrap, name=name, params=params)


def _wrap(env: gym.Env, name: str, params: tuple[tuple[str, Any], ...] = ()) -> gym.Wrapper:
    from imimic_gym.wrappers import RegistryObservation

    return RegistryObservation(env, name, keep_frame=False, **dict(params))


def _oracle(env: gym.Env):
    from imimic_gym.controllers import OracleController

    return OracleController(env)


def _learned(env: gym.Env):
    from imimic_gym.controllers.learned import LearnedController

    return LearnedController(env)


def _scripted(name: str) -> Callable[[gym.Env], Any]:
    def build(env: gym.Env):
        from imimic_gym.controllers import SCRIPTED_CONTROLLERS

        return SCRIPTED_CONTROLLERS[name](env)

    return build


# Controller name -> (the env's control mode, factory taking the wrapped env). The oracle
# reads the truth one frame ahead from the env itself and ignores the estimate. The
# scripted ones keep the start pose until the estimator's first reading (`EstimateTarget`).
# The learned tracker's control mode is that of its env's shipped checkpoint
# (`RunConfig.control`).
CONTROLLERS: dict[str, tuple[str, Callable[[gym.Env], Any]]] = {
    "oracle": ("position", _oracle),
    "position": ("position", _scripted("position")),
    "velocity": ("velocity", _scripted("velocity")),
    "torque": ("torque", _scripted("torque")),
    "learned": ("position", _learned),
}


@dataclass(frozen=True)
class RunConfig:
    """One cell of the grid: a scenario, an estimator (with its ``estimator_params``,
    (name, value) pairs such as the CNN's checkpoint), a controller, the clip seeds."""

    scenario: str
    estimator: str
    controller: str
    seeds: tuple[int, ...]
    frames: int | None = None
    estimator_params: tuple[tuple[str, Any], ...] = ()

    def __post_init__(self) -> None:
        get_scenario(self.scenario)
        for kind, name, registry in (("estimator", self.estimator, ESTIMATORS),
                                     ("controller", self.controller, CONTROLLERS)):
            if name not in registry:
                raise ValueError(f"unknown {kind} {name!r}; expected one of {sorted(registry)}")

    @property
    def control(self) -> str:
        if self.controller == "learned":
            from imimic_gym.controllers.learned import DEFAULT_CHECKPOINTS, checkpoint_control

            return checkpoint_control(DEFAULT_CHECKPOINTS[self.env_id])
        return CONTROLLERS[self.controller][0]

    @property
    def env_id(self) -> str:
        """``ImitateVideo3D-v0`` (the SO-101) for a spatial scenario, else the planar v0."""
        return "ImitateVideo3D-v0" if get_scenario(self.scenario).spatial else "ImitateVideo-v0"

    def env_kwargs(self) -> dict[str, Any]:
        kwargs: dict[str, Any] = {"scenario": self.scenario, "control": self.control,
                                  "clip_seeds": self.seeds}
        if self.frames:
            kwargs["n_frames"] = self.frames
        return kwargs

    def make_env(self) -> gym.Env:
        return _wrap(gym.make(self.env_id, **self.env_kwargs()), self.estimator,
                     self.estimator_params)


def run_config(config: RunConfig, num_envs: int = 1) -> list[Trajectory]:
    """One trajectory per seed of ``config``, in seed order. ``num_envs > 1`` steps that
    many clips at once through ``gym.make_vec`` (async: one process each; the oracle
    controller, which reads its sub-env's clip, runs them in sync mode)."""
    if num_envs <= 1:
        env = config.make_env()
        controller = CONTROLLERS[config.controller][1](env)
        out = [run_episode(env, controller, seed=s, options={"clip_seed": s})
               for s in config.seeds]
        env.close()
        return out
    return _run_vector(config, num_envs)


def _run_vector(config: RunConfig, num_envs: int) -> list[Trajectory]:
    sync = config.controller == "oracle"
    if not sync:
        # Render the clips into the cache once, here, rather than in each sub-env.
        spec = get_scenario(config.scenario,
                            **({"n_frames": config.frames} if config.frames else {}))
        for seed in config.seeds:
            load_clip(spec.replace(seed=seed))
    vec = cast("gym.vector.SyncVectorEnv | gym.vector.AsyncVectorEnv",
               gym.make_vec(config.env_id, num_envs=num_envs,
                            vectorization_mode="sync" if sync else "async",
                            wrappers=[estimator_wrapper(config.estimator,
                                                        config.estimator_params)],
                            **config.env_kwargs()))
    factory = CONTROLLERS[config.controller][1]
    template = None if sync else config.make_env()
    if template is None:
        assert isinstance(vec, gym.vector.SyncVectorEnv)  # the sync mode's
        views: list[gym.Env] = list(vec.envs)
    else:
        views = [template] * num_envs
    controllers = [factory(view) for view in views]
    fps = float(views[0].metadata["render_fps"])
    out: list[Trajectory] = []
    try:
        for start in range(0, len(config.seeds), num_envs):
            batch = list(config.seeds[start:start + num_envs])
            batch += [batch[-1]] * (num_envs - len(batch))  # idle sub-envs replay a seed
            out += _vector_episode(vec, controllers, batch, fps)[: len(config.seeds) - start]
    finally:
        vec.close()
        if template is not None:
            template.close()
    return out


def _vector_episode(vec: gym.vector.SyncVectorEnv | gym.vector.AsyncVectorEnv,
                    controllers: list, seeds: list[int], fps: float) -> list[Trajectory]:
    """One clip per sub-env (all clips of a scenario have the same length), stepped in
    lockstep; each sub-env's frames logged as `rollout.episode` logs one env's."""
    vec.set_attr("clip_seeds", [(s,) for s in seeds])
    obs, info = vec.reset(seed=cast("list[int | None]", seeds))  # the stub's list is invariant
    for controller in controllers:
        controller.reset()
    logs = [TrajectoryLog(fps=fps) for _ in seeds]
    reward, done = np.zeros(len(seeds)), np.zeros(len(seeds), dtype=bool)
    while True:
        single = [{k: v[i] for k, v in obs.items()} for i in range(len(seeds))]
        actions = np.stack([c(o) for c, o in zip(controllers, single, strict=True)])
        for i, log in enumerate(logs):
            log.add(Step(single[i], {k: v[i] for k, v in info.items()}, float(reward[i]),
                         actions[i], 0.0))
        if done.all():
            return [log.trajectory() for log in logs]
        obs, reward, terminated, truncated, info = vec.step(actions)
        done = terminated | truncated


def summarise(config: RunConfig, trajectories: Sequence[Trajectory]) -> dict[str, Any]:
    """Per-seed metrics and their means (`summarise_rows`)."""
    return summarise_rows(config, [
        {"seed": s, **t.metrics()} for s, t in zip(config.seeds, trajectories, strict=True)])


def summarise_rows(config: RunConfig, rows: Sequence[dict[str, Any]]) -> dict[str, Any]:
    """``config``'s result from its per-seed rows (``{"seed": s, **Trajectory.metrics()}``,
    in seed order): the rows and each metric's mean (a metric that is None for every seed,
    such as the recovery time without occlusion, stays None)."""
    rows = list(rows)
    mean: dict[str, float | None] = {}
    for key in METRICS:
        values = [r[key] for r in rows if r[key] is not None]
        mean[key] = float(np.mean(values)) if values else None
    return {"scenario": config.scenario, "estimator": config.estimator,
            "controller": config.controller, "control": config.control,
            "episodes": len(rows), "seeds": list(config.seeds), "mean": mean, "rows": rows}


def run_suite(configs: Sequence[RunConfig], num_envs: int = 1,
              on_trajectory: Callable[[RunConfig, Trajectory], None] | None = None,
              ) -> list[dict[str, Any]]:
    """Run every config (a progress bar over them) and summarise each.
    ``on_trajectory`` gets each config's first trajectory (for plots)."""
    return list(iter_suite(configs, num_envs, on_trajectory))


def iter_suite(configs: Sequence[RunConfig], num_envs: int = 1,
               on_trajectory: Callable[[RunConfig, Trajectory], None] | None = None,
               ) -> Iterator[dict[str, Any]]:
    """`run_suite` one config at a time: each summary as soon as its config has run, so
    a caller stopped midway (Ctrl-C) keeps those before."""
    for config in tqdm(configs, desc="imimic eval", unit="run"):
        trajectories = run_config(config, num_envs=num_envs)
        if on_trajectory is not None:
            on_trajectory(config, trajectories[0])
        yield summarise(config, trajectories)
