"""Where DON's angle error is, frame by frame, on DEVELOPMENT clips (seeds below 1000).

Every frame after the 0.5 s warm-up falls in one state of DON: before its pivot is agreed
(a guess), hidden (the link vanished while turning and is held), missing (no reading this
frame, held), or a reading. Per scenario it prints each state's frames, RMSE (deg) and
share of the squared error, and how many of the hidden frames are not occluded at all
(under 10% of the link hidden in truth). It chose nothing; it says where to look.

    .venv/bin/python benchmarks/don_error_sources.py \\
        --json benchmarks/results/don_error_sources.json
"""

from __future__ import annotations

import argparse
import json
import os
from multiprocessing import Pool
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")

import numpy as np

from imimic_gym.bench import machine
from imimic_gym.clips.cache import load_clip
from imimic_gym.clips.scenarios import get_scenario
from imimic_gym.estimators.don import DON
from imimic_gym.evaluation import WARM_UP_S
from imimic_gym.kinematics import wrap_angle
from imimic_gym.metrics import OCCLUDED

STATES = ("before pivot", "hidden", "missing", "reading")


def frame_states(job: tuple[str, int]) -> list[tuple[str, float, bool]]:
    """(state, error deg, occluded in truth) for each frame of one clip after warm-up."""
    scenario, seed = job
    spec = get_scenario(scenario, seed=seed)
    clip = load_clip(spec, progress=False)
    don = DON(fps=clip.fps, reference_direction=spec.reference_direction,
              joint_range=spec.joint_ranges[0])
    don.reset()
    warm = round(WARM_UP_S * clip.fps)
    rows = []
    for index, frame in enumerate(clip.frames):
        estimate = don.update(frame)
        if index < warm:
            continue
        if don.link.pivot() is None:
            state = "before pivot"
        elif don.hidden:
            state = "hidden"
        elif don.missing:
            state = "missing"
        else:
            state = "reading"
        error = float(np.degrees(wrap_angle(estimate.angles[0] - clip.truth.angles[index, 0])))
        rows.append((state, error, bool(clip.truth.occlusion[index] > OCCLUDED)))
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--scenarios", nargs="+", default=["exp3-forearm-none",
                        "exp3-forearm-low", "exp3-forearm-high"], help="default: %(default)s")
    parser.add_argument("--seeds", type=int, default=20,
                        help="development clip seeds 0 .. N-1 (default: %(default)s)")
    parser.add_argument("--json", default=None, help="also write the results to this file")
    args = parser.parse_args()
    results = []
    with Pool(os.cpu_count() or 1) as pool:
        for scenario in args.scenarios:
            frames = [r for clip in pool.map(frame_states,
                                             [(scenario, s) for s in range(args.seeds)])
                      for r in clip]
            total = sum(error**2 for _, error, _ in frames)
            print(f"{scenario}: settled RMSE, pooled over the frames, "
                  f"{np.sqrt(total / len(frames)):.2f} deg")
            states = {}
            for state in STATES:
                errors = np.array([e for s, e, _ in frames if s == state])
                clear = sum(1 for s, _, o in frames if s == state and not o)
                if not len(errors):
                    continue
                states[state] = {"frames": len(errors),
                                 "rmse_deg": float(np.sqrt(np.mean(errors**2))),
                                 "share_of_squared_error": float(np.sum(errors**2) / total),
                                 "not_occluded_frames": clear}
                print(f"  {state:13s} {len(errors):5d} frames, RMSE "
                      f"{states[state]['rmse_deg']:5.1f} deg, "
                      f"{100 * states[state]['share_of_squared_error']:3.0f}% of the squared "
                      f"error, {clear} of them not occluded")
            results.append({"scenario": scenario, "states": states})
    if args.json:
        Path(args.json).write_text(json.dumps({"machine": machine(), "seeds": args.seeds,
                                               "results": results}, indent=2) + "\n")


if __name__ == "__main__":
    main()
