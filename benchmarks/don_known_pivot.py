"""How much of DON's error on the person clips is the pivot: DON finding the elbow itself
(the default) against DON told where the elbow is (``DON(pivot=...)``, the mean of the
clip's true elbow keypoint), on the same held-out clips.

Settled RMSE (deg, after the first 0.5 s, as `imimic eval`) per clip and the mean; also
the distance (input px) between the pivot DON found and the true elbow at the last frame.

    .venv/bin/python benchmarks/don_known_pivot.py --json benchmarks/results/don_known_pivot.json
"""

from __future__ import annotations

import argparse
import json
import os
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")

import numpy as np
from tqdm import tqdm

from imimic_gym.bench import machine
from imimic_gym.clips.cache import load_clip
from imimic_gym.clips.scenarios import get_scenario
from imimic_gym.estimators.don import DON
from imimic_gym.evaluation import WARM_UP_S
from imimic_gym.metrics import angle_rmse_deg

SCENARIOS = ("exp3-forearm-none", "exp3-forearm-low", "exp3-forearm-high")
ELBOW = 1  # keypoint index of the elbow in a one-link person clip


def run(scenario: str, seeds: range) -> dict:
    rows = []
    for seed in tqdm(seeds, desc=scenario, leave=False):
        spec = get_scenario(scenario, seed=seed)
        clip = load_clip(spec, progress=False)
        elbow = clip.truth.keypoints[:, ELBOW].mean(axis=0)
        warm = round(WARM_UP_S * clip.fps)
        row: dict = {"seed": seed}
        for name, pivot in (("found", None), ("given", tuple(float(v) for v in elbow))):
            don = DON(fps=clip.fps, reference_direction=spec.reference_direction,
                      joint_range=spec.joint_ranges[0], pivot=pivot)
            angles = np.array([e.angles for e in don.run(clip.frames)])
            row[f"rmse_deg_settled_pivot_{name}"] = angle_rmse_deg(angles[warm:],
                                                                   clip.truth.angles[warm:])
            if pivot is None:
                found = don.link.pivot()
                row["pivot_error_px"] = (None if found is None else
                                         float(np.hypot(*(found * don.scale - elbow))))
        rows.append(row)
    mean = {key: float(np.mean([r[key] for r in rows]))
            for key in ("rmse_deg_settled_pivot_found", "rmse_deg_settled_pivot_given")}
    errors = [r["pivot_error_px"] for r in rows if r["pivot_error_px"] is not None]
    mean["pivot_error_px_median"] = float(np.median(errors)) if errors else None
    mean["pivot_never_found"] = sum(r["pivot_error_px"] is None for r in rows)
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
    for r in results:
        m = r["mean"]
        print(f"{r['scenario']:18s} pivot found {m['rmse_deg_settled_pivot_found']:5.1f} deg, "
              f"given {m['rmse_deg_settled_pivot_given']:5.1f} deg; found pivot off by "
              f"{m['pivot_error_px_median']:.0f} px (median)")
    command = (".venv/bin/python benchmarks/don_known_pivot.py --json "
               f"{args.json.as_posix()}")
    args.json.parent.mkdir(parents=True, exist_ok=True)
    args.json.write_text(json.dumps({"command": command, "machine": machine(),
                                     "results": results}, indent=2) + "\n")
    print(f"wrote {args.json}")


if __name__ == "__main__":
    main()
