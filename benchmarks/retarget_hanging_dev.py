"""Development only: `DirectionRetargeter`'s ``hanging_power`` against an estimate's error.
The spatial scenarios' DEVELOPMENT seeds, the pose model's readings replayed from the cache
of `pose3d_spatial_dev.py`; per clip, the truth and `pose3d`'s arm are each retargeted
frame by frame (continuing their own last targets; a frame without a reading holds).

    python benchmarks/retarget_hanging_dev.py --cache /tmp/p3d --seeds 1-12 --powers 0 1 2 4

Printed per power and scenario, means over the clips (degrees): the joint RMSE of
`pose3d`'s targets against the truth's (six joints, frames from the first reading; the
worst three clips beside), the truth's fidelity (RMSE over frames of the robot's upper arm
and forearm at the truth's targets against the person's, no servo lag), and the share of
frames in which some joint of the truth's targets moves at the step limit.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from pose3d_spatial_dev import SCENARIOS, cache, parse_setting, replay, seeds

from imimic_gym.retarget import DirectionRetargeter, robot_arm_directions
from imimic_gym.spatial import ArmPose, angle_between


def clip_figures(data: dict, power: float) -> tuple[float, float, float, float]:
    """(estimate-vs-truth joint RMSE, truth's upper-arm and forearm fidelity RMSE, share of
    frames at the step limit) for one clip."""
    retarget = DirectionRetargeter(hanging_power=power)
    poses = replay(data, parse_setting("filter"), set())
    estimate = truth = None
    errors, fidelity, steps = [], [], []
    for pose, points, pixels in zip(poses, data["points3d"], data["points2d"], strict=True):
        person = ArmPose(data["side"], points, np.ones(7), pixels)
        target = retarget(person, truth)
        if truth is not None:
            steps.append(float(np.abs(target - truth).max()))
        truth = target
        if pose is not None:
            estimate = retarget(pose, estimate)
        upper, fore = robot_arm_directions(retarget.spec, truth)
        fidelity.append([float(angle_between(upper, person.in_arm_frame(person.upper_arm))),
                         float(angle_between(fore, person.in_arm_frame(person.forearm)))])
        if estimate is not None:
            errors.append(estimate - truth)
    e, f = np.degrees(np.array(errors)), np.degrees(np.array(fidelity))
    at_limit = float(np.mean(np.array(steps) >= retarget.max_step - 1e-6))
    return (math.sqrt(float((e ** 2).mean())), math.sqrt(float((f[:, 0] ** 2).mean())),
            math.sqrt(float((f[:, 1] ** 2).mean())), at_limit)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--cache", type=Path, required=True)
    parser.add_argument("--seeds", type=seeds, default=seeds("1-12"))
    parser.add_argument("--powers", type=float, nargs="+", default=[0.0, 2.0])
    args = parser.parse_args()
    clips = {(s, seed): cache(args.cache, s, seed) for s in SCENARIOS for seed in args.seeds}
    for power in args.powers:
        print(f"hanging_power {power:g}")
        rows = {key: clip_figures(data, power) for key, data in clips.items()}
        for scenario in (*SCENARIOS, "all"):
            a = np.array([r for (s, _), r in rows.items() if scenario in ("all", s)])
            worst = " ".join(f"{w:.1f}" for w in sorted(a[:, 0])[::-1][:3])
            print(f"  {scenario:14s} joint RMSE {a[:, 0].mean():5.1f} (worst {worst}) | "
                  f"truth's upper {a[:, 1].mean():5.1f} forearm {a[:, 2].mean():5.1f} | "
                  f"at step limit {100 * a[:, 3].mean():4.1f}%")


if __name__ == "__main__":
    main()
