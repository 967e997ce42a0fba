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
from don_dev_seeds import run_clip
from tqdm import tqdm

from imimic_gym.bench import machine

SCENARIOS = ("exp3-forearm-none", "exp3-forearm-low", "exp3-forearm-high")


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
