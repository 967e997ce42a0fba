"""Oracle tracking accuracy: how well each robot actuation mode follows the TRUE angles.

This is the control loop's upper bound (no vision involved), per scenario and control
mode, over held-out clip seeds. Usage:

    .venv/bin/python benchmarks/oracle_tracking.py --json benchmarks/results/oracle.json
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import gymnasium as gym
import numpy as np

import imimic_gym
from imimic_gym.bench import machine
from imimic_gym.controllers import OracleController
from imimic_gym.rollout import run_episode

CONTROLS = ("position", "velocity", "torque")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, nargs="+", default=[100, 101, 102],
                        help="held-out clip seeds (default: %(default)s)")
    parser.add_argument("--json", default=None, help="write the table to this file")
    args = parser.parse_args()

    rows = []
    for scenario in imimic_gym.scenario_names():
        for control in CONTROLS:
            env = gym.make("ImitateVideo-v0", scenario=scenario, control=control,
                           clip_seeds=tuple(args.seeds))
            runs = [
                run_episode(env, OracleController(env), seed=0,
                            options={"clip_seed": seed}).metrics()
                for seed in args.seeds
            ]
            row = {
                "scenario": scenario,
                "control": control,
                "rmse_deg": float(np.mean([r["rmse_deg"] for r in runs])),
                "max_error_deg": float(np.max([r["max_error_deg"] for r in runs])),
                "lag_frames": float(np.mean([r["lag_frames"] for r in runs])),
            }
            rows.append(row)
            print(f"{scenario:20s} {control:9s} rmse {row['rmse_deg']:5.2f} deg  "
                  f"max {row['max_error_deg']:5.2f} deg  lag {row['lag_frames']:.1f} frames",
                  flush=True)
    if args.json:
        Path(args.json).write_text(json.dumps(
            {"machine": machine(), "seeds": args.seeds, "rows": rows}, indent=2) + "\n")


if __name__ == "__main__":
    main()
