"""Where the velocity controller's error on a scenario comes from (issue 5).

Splits the tracking error of DON + the velocity controller into its parts, over held-out
clips:
- the dynamics floor: the same controllers fed the TRUE angles, omega and alpha
  (the oracle estimator), so only the robot's own lag is left;
- DON's estimate itself: its angle error on the frame it describes, its omega error
  against the truth's central difference, and the error of two next-frame predictions
  (angle + omega / fps, and angle + the angle's own last change), from DON's first
  reading on (its trust above 0);
- a diagnostic velocity controller (defined only here, not a package controller) that
  feeds forward the last change of DON's angle instead of DON's omega;
- a diagnostic position controller (also only here) that follows the estimate from the
  first frame, placeholder included, as the package's did before it waited for the
  estimator's first reading: what that wait is worth.

    .venv/bin/python benchmarks/servo_error_sources.py \
        --json benchmarks/results/servo_error_sources.json
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

import imimic_gym  # noqa: F401  (registers ImitateVideo-v0)
from imimic_gym.bench import machine
from imimic_gym.controllers import SCRIPTED_CONTROLLERS
from imimic_gym.controllers.scripted import EstimateTarget
from imimic_gym.rollout import run_episode
from imimic_gym.suite import FIRST_HELD_OUT_SEED, estimator_wrapper
from imimic_gym.wrappers import estimate_fields


class DifferenceFeedForward:
    """Velocity command = dq + kp * (q_est - q), dq the last change of the estimated
    angle times fps (rad/s), holding the start pose until the estimator's first reading.
    The velocity controller with DON's omega swapped for that difference."""

    def __init__(self, env: gym.Env, kp: float = 2 * np.pi * 4.0) -> None:
        self.env, self.kp = env.unwrapped, kp
        self.fps = float(self.env.clip.fps)
        self.reference = EstimateTarget(env, 0.0)

    def reset(self) -> None:
        self.reference.reset()
        self.previous: np.ndarray | None = None

    def __call__(self, obs: dict[str, Any]) -> np.ndarray:
        angles = self.reference.reference(obs)[0]
        previous = angles if self.previous is None else self.previous
        self.previous = angles
        command = (angles - previous) * self.fps + self.kp * (angles - obs["qpos"])
        return self.env.command_to_action(command)


class ChasingPosition:
    """The position servo's target is the estimated angle led by one frame of omega from
    the first frame on, DON's placeholder (trust 0) included."""

    def __init__(self, env: gym.Env) -> None:
        self.env, self.fields = env.unwrapped, estimate_fields(1)
        self.lead_s = 1.0 / float(self.env.clip.fps)

    def reset(self) -> None:
        """Stateless."""

    def __call__(self, obs: dict[str, Any]) -> np.ndarray:
        estimate = obs["estimate"].astype(np.float64)
        target = estimate[self.fields["angles"]] + self.lead_s * estimate[self.fields["omega"]]
        return self.env.command_to_action(target)


def rms_deg(values: list[np.ndarray]) -> float:
    return float(np.degrees(np.sqrt(np.mean(np.concatenate(values) ** 2))))


def estimate_errors(scenario: str, seeds: list[int]) -> dict[str, float]:
    """DON's own errors (deg, deg/s), pooled over the seeds' frames from DON's first
    reading on (before it, DON reports a placeholder with trust 0 and every controller
    holds the start pose)."""
    env = estimator_wrapper("don")(gym.make("ImitateVideo-v0", scenario=scenario,
                                     control="velocity", clip_seeds=tuple(seeds)))
    fields = estimate_fields(1)
    parts: dict[str, list[np.ndarray]] = {k: [] for k in
                                          ("angle", "omega", "lead_omega", "lead_difference")}
    for seed in seeds:
        obs, _ = env.reset(seed=seed, options={"clip_seed": seed})
        truth = env.unwrapped.clip.truth.angles[:, 0]
        fps = float(env.unwrapped.clip.fps)
        angles, omegas, trust, done = [], [], [], False
        while True:
            angles.append(obs["estimate"][fields["angles"]][0])
            omegas.append(obs["estimate"][fields["omega"]][0])
            trust.append(obs["estimate"][fields["trust"]][0])
            if done:
                break
            obs, _, _, done, _ = env.step(np.zeros(1, dtype=np.float32))
        a, w = np.array(angles), np.array(omegas)
        moved = np.flatnonzero(np.array(trust) > 0)
        start = int(moved[0]) if len(moved) else len(a) - 1
        s = slice(start, None)
        parts["angle"].append(a[s] - truth[s])
        parts["omega"].append(w[s] - np.gradient(truth)[s] * fps)
        now, then = slice(max(start, 1), -1), slice(max(start, 1) + 1, None)
        parts["lead_omega"].append(a[now] + w[now] / fps - truth[then])
        before = slice(max(start, 1) - 1, -2)
        parts["lead_difference"].append(2 * a[now] - a[before] - truth[then])
    env.close()
    return {f"{k}_rmse": rms_deg(v) for k, v in parts.items()}


def tracking(scenario: str, estimator: str, name: str, seeds: list[int]) -> dict[str, Any]:
    env = estimator_wrapper(estimator)(gym.make("ImitateVideo-v0", scenario=scenario,
                                         control="velocity" if "velocity" in name or
                                         name == "difference" else "position",
                                         clip_seeds=tuple(seeds)))
    if name == "difference":
        controller = DifferenceFeedForward(env)
    elif name == "chasing":
        controller = ChasingPosition(env)
    else:
        controller = SCRIPTED_CONTROLLERS[name](env)
    runs = [run_episode(env, controller, seed=s, options={"clip_seed": s}).metrics()
            for s in seeds]
    env.close()
    return {"estimator": estimator, "controller": name,
            "rmse_deg": float(np.mean([r["rmse_deg"] for r in runs])),
            "lag_frames": float(np.mean([r["lag_frames"] for r in runs])),
            "jerk_deg_s3": float(np.mean([r["jerk_deg_s3"] for r in runs]))}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--scenario", default="exp2-servo", help="default: %(default)s")
    parser.add_argument("--seeds", type=int, nargs="+",
                        default=list(range(FIRST_HELD_OUT_SEED, FIRST_HELD_OUT_SEED + 10)),
                        help="clip seeds (default: the held-out %(default)s)")
    parser.add_argument("--json", default=None, help="write the results to this file")
    args = parser.parse_args()
    rows = [tracking(args.scenario, estimator, name, args.seeds)
            for estimator, name in (("oracle", "position"), ("oracle", "velocity"),
                                    ("don", "position"), ("don", "velocity"),
                                    ("don", "difference"), ("don", "chasing"))]
    for row in rows:
        print(f"{row['estimator']:7s} {row['controller']:14s} rmse {row['rmse_deg']:5.2f} deg "
              f"lag {row['lag_frames']:4.1f} frames jerk {row['jerk_deg_s3']:8.0f} deg/s^3")
    errors = estimate_errors(args.scenario, args.seeds)
    print("DON " + ", ".join(f"{k} {v:.2f}" for k, v in errors.items()))
    if args.json:
        Path(args.json).write_text(json.dumps(
            {"machine": machine(), "scenario": args.scenario, "seeds": args.seeds,
             "rows": rows, "don": errors}, indent=2) + "\n")


if __name__ == "__main__":
    main()
