"""Compare candidate tracker policies on VALIDATION clips (seeds below 1000), the way the
shipped `imimic_gym/data/checkpoints/tracker.pt` was chosen (issue 5).

Each candidate is a ``.pt`` written by ``training/train_tracker.py`` with its ``.json``
beside it; it runs with DON on each scenario's validation seeds, next to the
velocity and position controllers on the same clips. Held-out seeds (1000 and
up) are refused: they are kept for the final figure.

    .venv/bin/python benchmarks/tracker_candidates.py run_a/tracker.pt run_b/tracker.pt \\
        --json benchmarks/results/tracker_candidates.json
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
from imimic_gym.controllers.learned import LearnedController
from imimic_gym.rollout import run_episode
from imimic_gym.suite import FIRST_HELD_OUT_SEED, estimator_wrapper

SCENARIOS = ("exp2-servo", "exp3-forearm-low")


def score(scenario: str, control: str, build: Any, seeds: list[int]) -> dict[str, float]:
    """Mean RMSE (deg) and jerk (deg/s^3) over ``seeds`` of the controller ``build(env)``."""
    env = estimator_wrapper("don")(gym.make("ImitateVideo-v0", scenario=scenario, control=control,
                                     clip_seeds=tuple(seeds)))
    controller = build(env)
    runs = [run_episode(env, controller, seed=s, options={"clip_seed": s}).metrics()
            for s in seeds]
    env.close()
    return {"rmse_deg": float(np.mean([r["rmse_deg"] for r in runs])),
            "jerk_deg_s3": float(np.mean([r["jerk_deg_s3"] for r in runs]))}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("checkpoints", nargs="+", help="candidate policies (.pt)")
    parser.add_argument("--seeds", type=int, nargs="+", default=list(range(900, 910)),
                        help="validation clip seeds, below 1000 (default: %(default)s)")
    parser.add_argument("--json", default=None, help="write the results to this file")
    args = parser.parse_args()
    if max(args.seeds) >= FIRST_HELD_OUT_SEED:
        parser.error(f"--seeds must stay below {FIRST_HELD_OUT_SEED} (held out), "
                     f"got {max(args.seeds)}")
    rows = []
    for control in ("position", "velocity"):
        for scenario in SCENARIOS:
            rows.append({"candidate": control, "scenario": scenario, **score(
                scenario, control, SCRIPTED_CONTROLLERS[control], args.seeds)})
    for path in args.checkpoints:
        meta_path = Path(path).with_suffix(".json")
        if not meta_path.is_file():
            raise FileNotFoundError(f"candidate {path} has no metadata {meta_path}")
        meta = json.loads(meta_path.read_text())
        for scenario in SCENARIOS:
            trained = meta.get("args", {})
            setup = {"control": meta["control"], "features_version": meta["features_version"],
                     "rate_history": meta.get("rate_history_frames", 0),
                     "reward_balance": trained.get("reward_balance"),
                     "gradient_steps": trained.get("gradient_steps", 1),
                     "total_timesteps": meta["total_timesteps"]}
            rows.append({"candidate": path, "command": meta["command"], "setup": setup,
                         "net_arch": meta["net_arch"],
                         "train_seconds": meta["train_seconds"], "scenario": scenario,
                         **score(scenario, meta["control"],
                                 lambda env, p=path: LearnedController(env, p), args.seeds)})
    for row in rows:
        print(f"{row['candidate']:40s} {row['scenario']:18s} rmse {row['rmse_deg']:6.2f} deg "
              f"jerk {row['jerk_deg_s3']:8.0f} deg/s^3", flush=True)
    if args.json:
        Path(args.json).write_text(json.dumps(
            {"machine": machine(), "seeds": args.seeds, "rows": rows}, indent=2) + "\n")


if __name__ == "__main__":
    main()
