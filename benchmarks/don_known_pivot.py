"""How much of DON's error on the person clips is the pivot: DON finding the elbow itself
(the default) against DON told where the elbow is (``DON(pivot=...)``, the mean of the
clip's true elbow keypoint), on the same held-out clips. Likewise for `LinkedDON` on the
two-link chain, with the shoulder as the root pivot.

Settled RMSE (deg, after the first 0.5 s, as `imimic eval`) per clip and the mean; also
the distance (input px) between the pivot DON found and the true one at the last frame.
For the chain, per joint, with the mean signed error (estimate minus truth, deg) too.

    .venv/bin/python benchmarks/don_known_pivot.py --json benchmarks/results/don_known_pivot.json
"""

from __future__ import annotations

import argparse
import json
import os
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")

import numpy as np
from don_dev_seeds import run_clip
from tqdm import tqdm

from imimic_gym.bench import machine
from imimic_gym.clips.cache import load_clip
from imimic_gym.clips.scenarios import get_scenario
from imimic_gym.estimators.registry import build_estimator
from imimic_gym.evaluation import WARM_UP_S, clip_context
from imimic_gym.kinematics import wrap_angle
from imimic_gym.metrics import angle_rmse_deg

SCENARIOS = ("exp3-forearm-none", "exp3-forearm-low", "exp3-forearm-high")
CHAINS = ("chain-2",)


def run(scenario: str, seeds: range) -> dict:
    rows = []
    for seed in tqdm(seeds, desc=scenario, leave=False):
        found, given = (run_clip((scenario, seed, {}, pivot_given))
                        for pivot_given in (False, True))
        rows.append({"seed": seed,
                     "rmse_deg_settled_pivot_found": found["rmse_deg_settled"],
                     "rmse_deg_settled_pivot_given": given["rmse_deg_settled"],
                     "pivot_error_px": found.get("pivot_error_px")})
    mean = {key: float(np.mean([r[key] for r in rows]))
            for key in ("rmse_deg_settled_pivot_found", "rmse_deg_settled_pivot_given")}
    errors = [r["pivot_error_px"] for r in rows if r["pivot_error_px"] is not None]
    mean["pivot_error_px_median"] = float(np.median(errors)) if errors else None
    mean["pivot_never_found"] = sum(r["pivot_error_px"] is None for r in rows)
    return {"scenario": scenario, "mean": mean, "rows": rows}


def run_chain_clip(scenario: str, seed: int, pivot_given: bool) -> dict:
    """`LinkedDON` on one clip, finding the shoulder or told it (the mean of the clip's
    true shoulder keypoint): per joint settled RMSE and mean signed error (deg), and how
    far (input px) the root pivot it used lies from the true shoulder."""
    spec = get_scenario(scenario, seed=seed)
    clip = load_clip(spec, progress=False)
    shoulder = clip.truth.keypoints[:, clip.truth.keypoint_names.index("shoulder")].mean(axis=0)
    params = {"pivot": tuple(float(v) for v in shoulder)} if pivot_given else {}
    don = build_estimator("don", clip_context(spec, clip), **params)
    angles = np.array([e.angles for e in don.run(clip.frames)])
    warm = round(WARM_UP_S * clip.fps)
    truth = clip.truth.angles[warm:]
    found = don.pivot()
    return {
        "rmse_deg_settled": [angle_rmse_deg(angles[warm:, j], truth[:, j])
                             for j in range(truth.shape[1])],
        "mean_error_deg": np.degrees(wrap_angle(angles[warm:] - truth).mean(axis=0)).tolist(),
        "pivot_error_px": (None if found is None
                           else float(np.hypot(*(found * don.scale - shoulder)))),
    }


def run_chain(scenario: str, seeds: range) -> dict:
    rows = []
    for seed in tqdm(seeds, desc=scenario, leave=False):
        rows.append({"seed": seed, **{f"pivot_{how}": run_chain_clip(scenario, seed, given)
                                      for how, given in (("found", False), ("given", True))}})
    mean = {how: {key: np.mean([r[how][key] for r in rows], axis=0).tolist()
                  for key in ("rmse_deg_settled", "mean_error_deg")}
            for how in ("pivot_found", "pivot_given")}
    errors = [r["pivot_found"]["pivot_error_px"] for r in rows
              if r["pivot_found"]["pivot_error_px"] is not None]
    mean["pivot_error_px_median"] = float(np.median(errors)) if errors else None
    return {"scenario": scenario, "mean": mean, "rows": rows}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--first-seed", type=int, default=1000,
                        help="first held-out clip seed (default: %(default)s)")
    parser.add_argument("--episodes", type=int, default=10,
                        help="clips per scenario (default: %(default)s)")
    parser.add_argument("--json", type=Path, required=True, help="where to write the result")
    args = parser.parse_args()
    seeds = range(args.first_seed, args.first_seed + args.episodes)
    results = [run(scenario, seeds) for scenario in SCENARIOS]
    chains = [run_chain(scenario, seeds) for scenario in CHAINS]
    for r in results:
        m = r["mean"]
        print(f"{r['scenario']:18s} pivot found {m['rmse_deg_settled_pivot_found']:5.1f} deg, "
              f"given {m['rmse_deg_settled_pivot_given']:5.1f} deg; found pivot off by "
              f"{m['pivot_error_px_median']:.0f} px (median)")
    for r in chains:
        m = r["mean"]
        print(f"{r['scenario']:18s} per joint, shoulder found "
              f"{', '.join(f'{v:.1f}' for v in m['pivot_found']['rmse_deg_settled'])} deg, "
              f"given {', '.join(f'{v:.1f}' for v in m['pivot_given']['rmse_deg_settled'])} "
              f"deg; found shoulder off by {m['pivot_error_px_median']:.0f} px (median)")
    command = (".venv/bin/python benchmarks/don_known_pivot.py --json "
               f"{args.json.as_posix()}")
    args.json.parent.mkdir(parents=True, exist_ok=True)
    args.json.write_text(json.dumps({"command": command, "machine": machine(),
                                     "results": results, "chains": chains}, indent=2) + "\n")
    print(f"wrote {args.json}")


if __name__ == "__main__":
    main()
