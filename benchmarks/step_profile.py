"""Where an ImitateVideo-v0 step spends its time, and what the physics step size costs.

Times each part of a step (physics, observation copy, info) with the env's settings, and
the physics alone at a 2 ms substep for comparison, with the position servo's tracking
error under both on the same target trajectory. Usage:

    .venv/bin/python benchmarks/step_profile.py --json benchmarks/results/step_profile.json
"""

from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path

import gymnasium as gym
import mujoco
import numpy as np

import imimic_gym  # noqa: F401
from imimic_gym.arms import build_arm_model
from imimic_gym.bench import machine

N = 3000


def per_call_us(fn, n: int = N) -> float:
    start = time.perf_counter()
    for _ in range(n):
        fn()
    return (time.perf_counter() - start) / n * 1e6


def servo_error_deg(model: mujoco.MjModel, substeps: int) -> float:
    """Largest error of the position servo following a 0.5 Hz sine sampled at 30 fps."""
    data = mujoco.MjData(model)
    centre = model.jnt_range.mean(axis=1)
    worst = 0.0
    for k in range(300):
        data.ctrl[:] = centre + 0.5 * math.sin(2 * math.pi * 0.5 * k / 30)
        mujoco.mj_step(model, data, nstep=substeps)
        target = centre + 0.5 * math.sin(2 * math.pi * 0.5 * (k + 1) / 30)
        if k >= 5:
            worst = max(worst, float(np.degrees(np.abs(data.qpos - target)).max()))
    return worst


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--json", default=None, help="write the results to this file")
    args = parser.parse_args()

    env = gym.make("ImitateVideo-v0")
    inner = env.unwrapped
    env.reset(seed=0)
    rng = np.random.default_rng(0)
    actions = rng.uniform(-1, 1, (N, 1)).astype(np.float32)
    it = iter(actions)

    def step() -> None:
        *_, truncated, _ = env.step(next(it))
        if truncated:
            env.reset()

    result = {"machine": machine(), "substeps": inner.n_substeps,
              "physics_step_ms": inner.model.opt.timestep * 1e3}
    result["step_us"] = per_call_us(step)
    result["physics_us"] = per_call_us(
        lambda: mujoco.mj_step(inner.model, inner.data, nstep=inner.n_substeps))
    inner.frame_index = 1
    result["observation_us"] = per_call_us(inner._obs)
    result["info_us"] = per_call_us(lambda: inner._info(*inner._tracking()))

    fine = build_arm_model(inner.arm)  # the same arm, with a step we may change
    fine_substeps = math.ceil(1 / 30 / 0.002)
    fine.opt.timestep = 1 / 30 / fine_substeps
    fine_data = mujoco.MjData(fine)
    result["physics_2ms_us"] = per_call_us(
        lambda: mujoco.mj_step(fine, fine_data, nstep=fine_substeps))
    result["servo_max_error_deg"] = servo_error_deg(inner.model, inner.n_substeps)
    result["servo_max_error_2ms_deg"] = servo_error_deg(fine, fine_substeps)
    for key, value in result.items():
        if key != "machine":
            print(f"{key:26s} {value:.2f}" if isinstance(value, float) else f"{key:26s} {value}")
    if args.json:
        Path(args.json).write_text(json.dumps(result, indent=2) + "\n")


if __name__ == "__main__":
    main()
