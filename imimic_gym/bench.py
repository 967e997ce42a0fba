"""Speed measurements behind `imimic bench`. Each speed is reported beside a reference
measured in the same run on the same machine, because absolute times on a shared machine
are noise."""

from __future__ import annotations

import os
import platform
import time
from typing import Any

import gymnasium as gym
import numpy as np

from imimic_gym.clips.cache import load_clip
from imimic_gym.clips.scenarios import get_scenario, scenario_names
from imimic_gym.clips.synthetic import render_clip

__all__ = ["bench_env", "bench_render", "machine"]


def machine() -> dict[str, Any]:
    import mujoco

    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as f:
            cpu = next(line.split(":", 1)[1].strip() for line in f if line.startswith("model name"))
    except (OSError, StopIteration):
        pass
    return {
        "cpu": cpu,
        "cores": os.cpu_count(),
        "python": platform.python_version(),
        "mujoco": mujoco.__version__,
        "gymnasium": gym.__version__,
        "numpy": np.__version__,
        "MUJOCO_GL": os.environ.get("MUJOCO_GL"),
    }


def _steps_per_second(env: gym.Env, actions: np.ndarray) -> float:
    env.reset(seed=0)
    start = time.perf_counter()
    for action in actions:
        _, _, terminated, truncated, _ = env.step(action)
        if terminated or truncated:
            env.reset()
    return len(actions) / (time.perf_counter() - start)


def bench_env(steps: int = 3000, repeats: int = 5, seed: int = 0) -> dict[str, Any]:
    """Steps/s of ImitateVideo-v0 (default scenario, clip from the cache, frames in the
    observation, through ``gym.make``'s wrappers) and of Gymnasium's Reacher-v5, with random
    actions, alternating ``repeats`` times; the medians and their ratio."""
    load_clip(get_scenario("default"), progress=False)  # the cache, not rendering, is timed
    imitate = gym.make("ImitateVideo-v0")
    reacher = gym.make("Reacher-v5")
    rng = np.random.default_rng(seed)
    runs: dict[str, list[float]] = {"imitate": [], "reacher": []}
    for _ in range(repeats):
        for name, env in (("imitate", imitate), ("reacher", reacher)):
            actions = rng.uniform(-1, 1, size=(steps, *env.action_space.shape)).astype(np.float32)
            runs[name].append(_steps_per_second(env, actions))
    imitate.close()
    reacher.close()
    imitate_sps, reacher_sps = float(np.median(runs["imitate"])), float(np.median(runs["reacher"]))
    return {
        "imitate_steps_per_s": imitate_sps,
        "reacher_steps_per_s": reacher_sps,
        "ratio": imitate_sps / reacher_sps,
        "steps": steps,
        "repeats": repeats,
    }


def bench_render(n_frames: int = 150, height: int = 240, width: int = 320) -> dict[str, float]:
    """Frames/s of rendering each scenario from scratch (no cache), truth included."""
    render_clip(get_scenario("default", n_frames=5), progress=False)  # GL warm-up
    fps = {}
    for name in scenario_names():
        spec = get_scenario(name, n_frames=n_frames, height=height, width=width)
        start = time.perf_counter()
        render_clip(spec, progress=False)
        fps[name] = n_frames / (time.perf_counter() - start)
    return fps
