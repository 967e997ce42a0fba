"""Development only: the retargeter's settings on the spatial scenarios' development clips,
followed by the simulated SO-101 (`ImitateVideo3D-v0`, `OracleController`: the truth
retargeted, the servos' own lag included).

    python benchmarks/retarget_dev.py --seeds 0-9 --setting '{}' --setting '{"jump_cost": 0}'

Printed per scenario and setting (means over the clips): the robot's joint RMSE against
its targets; the robot's upper-arm and forearm directions against the person's (in the
person's arm frame, through the mapping): RMSE and median over frames, and the median of
the worse of the two. Choose on seeds under 1000 only (docs/decisions/evaluation-protocol.md).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import gymnasium as gym
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from imimic_gym.controllers import OracleController
from imimic_gym.retarget import MAPPINGS, DirectionRetargeter, robot_arm_directions
from imimic_gym.rollout import run_episode
from imimic_gym.spatial import angle_between
from imimic_gym.spatial.truth import arm_poses

SCENARIOS = ("spatial-reach", "spatial-cup", "spatial-raise", "spatial-curl", "spatial-wave",
             "spatial")


def seeds_of(text: str) -> list[int]:
    first, _, last = text.partition("-")
    seeds = list(range(int(first), int(last or first) + 1))
    if max(seeds) >= 1000:
        raise SystemExit("development seeds are under 1000")
    return seeds


def clip_errors(scenario: str, seed: int, setting: dict, frames: int) -> dict[str, float]:
    env = gym.make("ImitateVideo3D-v0", scenario=scenario, n_frames=frames)
    inner = env.unwrapped
    inner.retarget = DirectionRetargeter(inner.robot_spec, mapping=MAPPINGS["mirror"],
                                         **setting)
    trajectory = run_episode(env, OracleController(env), seed=seed,
                             options={"clip_seed": seed})
    errors = []
    for q, pose in zip(trajectory.robot, arm_poses(inner.clip), strict=True):
        robot = robot_arm_directions(inner.robot_spec, np.asarray(q))
        person = (pose.in_arm_frame(pose.upper_arm), pose.in_arm_frame(pose.forearm))
        errors.append([math.degrees(float(angle_between(r, p)))
                       for r, p in zip(robot, person, strict=True)])
    env.close()
    e = np.array(errors)
    return {"joint_rmse": float(trajectory.metrics()["rmse_deg"]),
            "upper_rmse": float(np.sqrt((e[:, 0] ** 2).mean())),
            "fore_rmse": float(np.sqrt((e[:, 1] ** 2).mean())),
            "upper_median": float(np.median(e[:, 0])), "fore_median": float(np.median(e[:, 1])),
            "worse_of_two_median": float(np.median(e.max(axis=1)))}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seeds", default="0-9", help="development clip seeds, e.g. 0-9")
    parser.add_argument("--frames", type=int, default=120)
    parser.add_argument("--setting", action="append", default=[],
                        help="DirectionRetargeter keyword arguments as JSON (repeatable)")
    args = parser.parse_args()
    for setting in [json.loads(s) for s in args.setting] or [{}]:
        print(f"setting {setting}")
        rows = {s: [clip_errors(s, seed, setting, args.frames) for seed in seeds_of(args.seeds)]
                for s in SCENARIOS}
        every = [clip for clips in rows.values() for clip in clips]
        for scenario, clips in [*rows.items(), ("all", every)]:
            mean = {k: np.mean([c[k] for c in clips]) for k in clips[0]}
            print(f"  {scenario:14s} " + "  ".join(f"{k} {v:5.1f}" for k, v in mean.items()))


if __name__ == "__main__":
    main()
