"""LinkedDON on DEVELOPMENT clips (seeds below 1000), for choosing its rules without
touching the held-out clips that `imimic eval` reports.

Per scenario: the mean over clips of the settled RMSE per joint (deg, after the first
0.5 s, as `imimic eval`), each clip's row, and the distance (input px) from the root
pivot LinkedDON found to the true one (the first keypoint's mean over the clip). To
compare with an earlier revision, run the same command in a checkout of it. LinkedDON
starts from the colour preset (`config.linked_don_preset`); any field of
`LinkedDONConfig` can be set with ``--param NAME=VALUE`` (repeatable; ``colour.NAME`` for
the appearance layer's).

    .venv/bin/python benchmarks/don_links_dev_seeds.py                     # defaults
    .venv/bin/python benchmarks/don_links_dev_seeds.py --scenarios chain-2 --seeds 0 10
    .venv/bin/python benchmarks/don_links_dev_seeds.py --param band=7.0 --param threshold=6
"""

from __future__ import annotations

import argparse
import json
import os
from multiprocessing import Pool
from pathlib import Path
from typing import Any

os.environ.setdefault("MUJOCO_GL", "egl")

import numpy as np

from imimic_gym.bench import machine
from imimic_gym.clips.cache import load_clip
from imimic_gym.clips.scenarios import get_scenario
from imimic_gym.estimators.don.config import linked_don_preset, override, parse_setting
from imimic_gym.estimators.registry import build_estimator
from imimic_gym.evaluation import WARM_UP_S, clip_context
from imimic_gym.metrics import angle_rmse_deg
from imimic_gym.suite import FIRST_HELD_OUT_SEED

# Development seeds per scenario: the hand's per-joint figures swing from clip to clip,
# so it gets more of them.
DEFAULT_SEEDS = {"chain-2": (0, 30), "chain-3": (0, 20), "exp4-hand": (0, 40)}


def run_clip(job: tuple[str, int, dict[str, Any]]) -> dict:
    """One development clip: settled RMSE per joint (deg) and the root pivot's error,
    LinkedDON's colour preset with ``params`` overridden."""
    scenario, seed, params = job
    spec = get_scenario(scenario, seed=seed)
    clip = load_clip(spec, progress=False)
    don = build_estimator("don", clip_context(spec, clip),
                          config=override(linked_don_preset("rgb"), params))
    angles = np.array([e.angles for e in don.run(clip.frames)])
    warm = round(WARM_UP_S * clip.fps)
    settled = [round(angle_rmse_deg(angles[warm:, j], clip.truth.angles[warm:, j]), 3)
               for j in range(angles.shape[1])]
    pivot = don.pivot()
    truth = clip.truth.keypoints[:, 0].mean(axis=0)
    return {"seed": seed,
            "rmse_deg_settled": settled,
            "pivot_error_px": (None if pivot is None
                               else round(float(np.hypot(*(pivot * don.scale - truth))), 2))}


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--scenarios", nargs="+", default=list(DEFAULT_SEEDS),
                        help="several-link scenarios (default: %(default)s)")
    parser.add_argument("--seeds", nargs=2, type=int, metavar=("FIRST", "END"),
                        help="clip seeds FIRST..END-1 for every scenario (default: "
                             "chain-2 0-29, chain-3 0-19, exp4-hand 0-39)")
    parser.add_argument("--param", type=parse_setting, action="append", default=[],
                        help="a LinkedDONConfig field, NAME=VALUE (repeatable)")
    parser.add_argument("--json", type=Path, help="also write the results here")
    args = parser.parse_args(argv)
    params = dict(args.param)
    override(linked_don_preset("rgb"), params)  # an unknown field fails here
    results = []
    with Pool(2) as pool:
        for scenario in args.scenarios:
            first, end = args.seeds or DEFAULT_SEEDS.get(scenario, (0, 20))
            if end > FIRST_HELD_OUT_SEED:
                parser.error(f"seeds from {FIRST_HELD_OUT_SEED} on are held out")
            rows = pool.map(run_clip, [(scenario, seed, params) for seed in range(first, end)])
            mean = np.mean([r["rmse_deg_settled"] for r in rows], axis=0)
            results.append({"scenario": scenario, "seeds": [first, end],
                            "mean_rmse_deg_settled": mean.round(2).tolist(), "rows": rows})
            print(f"{scenario:10s} seeds {first}-{end - 1}: settled RMSE per joint "
                  f"{', '.join(f'{v:.2f}' for v in mean)} deg")
    if args.json:
        args.json.write_text(json.dumps({"machine": machine(), "params": params,
                                         "results": results}, indent=1))
        print(f"wrote {args.json}")


if __name__ == "__main__":
    main()
