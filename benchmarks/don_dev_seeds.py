"""DON on DEVELOPMENT clips (seeds below 1000; 0-19 by default), for choosing its
parameters and rules without touching the held-out clips that `imimic eval` reports.

Per scenario: the mean settled RMSE (deg, after the first 0.5 s, as `imimic eval`), the
mean eta, on clips with occluded frames (over 10% of the link hidden) the RMSE on those
frames and eta on them and on the others, and the median distance (input px) from the
pivot DON found to the true elbow (person scenarios). DON starts from the modality's
preset (`config.don_preset`, as `imimic eval` builds it; ``--preset`` picks another) and
any field of `DONConfig` can be set with ``--param NAME=VALUE`` (repeatable; nested ones
as ``tracker.NAME`` or ``colour.NAME``); ``--pivot-given`` tells DON where the elbow is;
``--modality depth`` feeds it the clips' depth video instead of their colour.

``--compare FILE`` pairs this run clip by clip with an earlier ``--json FILE`` (same
scenarios and seeds) and prints, per scenario, the mean change of settled RMSE with a
95% bootstrap interval, how many clips got better and worse (by over 0.05 deg), and the
largest changes. A clip's error is heavy-tailed (a wrong pivot or a lost link costs tens
of degrees): a mean over 20 clips can move by a degree on one clip, so judge a change
by the interval and the counts, on more seeds where they are close.

80 seeds of the six default scenarios are 480 clips, about 28 GB: above the clip cache's
default bound, so set ``IMIMIC_CACHE_MAX_GB`` (e.g. ``inf``) to keep them between runs.

    .venv/bin/python benchmarks/don_dev_seeds.py                       # defaults
    .venv/bin/python benchmarks/don_dev_seeds.py --param trust_threshold=0.3 \\
        --scenarios exp3-forearm-low exp3-forearm-high
    .venv/bin/python benchmarks/don_dev_seeds.py --param gaussian=15 --param threshold=12
    .venv/bin/python benchmarks/don_dev_seeds.py --seeds 0 80 --json /tmp/before.json
    .venv/bin/python benchmarks/don_dev_seeds.py --seeds 0 80 \\
        --param search_when_lost=False --compare /tmp/before.json
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
from imimic_gym.clips.types import MODALITIES, depth_to_frame
from imimic_gym.estimators.don.config import don_preset, override, parse_setting
from imimic_gym.estimators.don.one_link import DON
from imimic_gym.evaluation import WARM_UP_S
from imimic_gym.metrics import OCCLUDED, angle_rmse_deg
from imimic_gym.suite import FIRST_HELD_OUT_SEED

SCENARIOS = ("exp3-forearm-none", "exp3-forearm-low", "exp3-forearm-high", "exp2-servo",
             "default", "exp1-noisy-fast")
ELBOW = 1  # keypoint index of the elbow in a one-link person clip


def run_clip(job: tuple[str, int, dict[str, Any], bool, str, str]) -> dict[str, Any]:
    """Scores for one clip: DON with the ``preset``'s config and ``params`` on
    ``scenario`` seed ``seed``, fed its colour or depth video (``modality``)."""
    scenario, seed, params, pivot_given, modality, preset = job
    spec = get_scenario(scenario, seed=seed)
    clip = load_clip(spec, progress=False)
    person = spec.demonstrator == "human"
    elbow = clip.truth.keypoints[:, ELBOW].mean(axis=0) if person else None
    pivot = tuple(float(v) for v in elbow) if pivot_given and person else None
    don = DON(fps=clip.fps, reference_direction=spec.reference_direction,
              joint_range=spec.joint_ranges[0], pivot=pivot,
              config=override(don_preset(preset), params))
    estimates = don.run(clip.frames if modality == "rgb" else depth_to_frame(clip.depth))
    angles = np.array([e.angles for e in estimates])
    trust = np.array([e.trust for e in estimates])
    warm = round(WARM_UP_S * clip.fps)
    row: dict[str, Any] = {
        "scenario": scenario, "seed": seed,
        "rmse_deg_settled": angle_rmse_deg(angles[warm:], clip.truth.angles[warm:]),
        "mean_trust": float(trust.mean()),
    }
    occluded = clip.truth.occlusion > OCCLUDED
    if occluded.any() and not occluded.all():
        row["rmse_occluded_deg"] = angle_rmse_deg(angles[occluded], clip.truth.angles[occluded])
        row["mean_trust_occluded"] = float(trust[occluded].mean())
        row["mean_trust_clear"] = float(trust[~occluded].mean())
    found = don.link.pivot() if don.link is not None else None
    if person and found is not None:
        row["pivot_error_px"] = float(np.hypot(*(found * don.scale - elbow)))
    return row


def summarise(rows: list[dict[str, Any]]) -> dict[str, float]:
    keys = ("rmse_deg_settled", "mean_trust", "rmse_occluded_deg", "mean_trust_occluded",
            "mean_trust_clear")
    out = {k: float(np.mean([r[k] for r in rows if k in r])) for k in keys
           if any(k in r for r in rows)}
    pivots = [r["pivot_error_px"] for r in rows if "pivot_error_px" in r]
    if pivots:
        out["pivot_error_px_median"] = float(np.median(pivots))
    return out


def compare(rows: list[dict[str, Any]], before: list[dict[str, Any]], scenario: str,
            resamples: int = 10_000) -> dict[str, Any]:
    """This run's settled RMSE against ``before``'s on the same clips of ``scenario``:
    mean before and after, the mean paired change (deg) and its 95% bootstrap interval
    (seeded), clips better and worse by over 0.05 deg, and the three largest changes as
    (seed, before, after)."""
    earlier = {r["seed"]: r["rmse_deg_settled"] for r in before if r["scenario"] == scenario}
    pairs = [(r["seed"], earlier[r["seed"]], r["rmse_deg_settled"]) for r in rows
             if r["scenario"] == scenario and r["seed"] in earlier]
    if not pairs:
        raise SystemExit(f"--compare: the earlier run has no clip of {scenario} with these seeds")
    seeds, old, new = (np.array(column) for column in zip(*pairs, strict=True))
    change = new - old
    means = change[np.random.default_rng(0).integers(0, len(change),
                                                     (resamples, len(change)))].mean(axis=1)
    largest = [i for i in np.argsort(-np.abs(change))[:3] if abs(change[i]) > 0.05]
    return {"clips": len(change), "before": float(old.mean()), "after": float(new.mean()),
            "change": float(change.mean()),
            "interval": [float(v) for v in np.percentile(means, [2.5, 97.5])],
            "better": int((change < -0.05).sum()), "worse": int((change > 0.05).sum()),
            "largest": [(int(seeds[i]), float(old[i]), float(new[i])) for i in largest]}


def parse_param(text: str) -> tuple[str, Any]:
    try:
        return parse_setting(text)
    except ValueError as error:
        raise argparse.ArgumentTypeError(str(error)) from None


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--scenarios", nargs="+", default=list(SCENARIOS),
                        help="one-link scenarios (default: %(default)s)")
    parser.add_argument("--seeds", type=int, nargs=2, default=(0, 20), metavar=("FIRST", "END"),
                        help="clip seeds FIRST..END-1, below 1000 (default: 0 20)")
    parser.add_argument("--param", type=parse_param, action="append", default=[],
                        help="a DONConfig field, NAME=VALUE (repeatable; tracker.NAME, "
                             "colour.NAME for the nested ones)")
    parser.add_argument("--preset", choices=MODALITIES, default=None,
                        help="the preset the params apply to (default: the modality's)")
    parser.add_argument("--pivot-given", action="store_true",
                        help="tell DON the true elbow (person scenarios)")
    parser.add_argument("--modality", choices=MODALITIES, default="rgb",
                        help="feed DON the clips' colour (default) or depth video, as "
                             "ImitateVideo-v0(modality=...) shows it")
    parser.add_argument("--processes", type=int, default=2, help="worker processes")
    parser.add_argument("--json", type=Path, default=None, help="also write the results here")
    parser.add_argument("--compare", type=Path, default=None, metavar="FILE",
                        help="pair the clips with an earlier --json FILE of the same seeds")
    args = parser.parse_args()
    first, end = args.seeds
    if end > FIRST_HELD_OUT_SEED:
        parser.error(f"development seeds stay below {FIRST_HELD_OUT_SEED} (held out)")
    params = dict(args.param)
    preset = args.preset or args.modality
    override(don_preset(preset), params)  # an unknown field fails here, not in a worker
    jobs = [(s, seed, params, args.pivot_given, args.modality, preset) for s in args.scenarios
            for seed in range(first, end)]
    with Pool(args.processes) as pool:
        rows = pool.map(run_clip, jobs)
    results = {s: summarise([r for r in rows if r["scenario"] == s]) for s in args.scenarios}
    print(f"DON {params or 'defaults'}{', pivot given' if args.pivot_given else ''}, "
          f"{args.modality}, development seeds {first}-{end - 1}")
    for scenario, m in results.items():
        occluded = (f", occluded frames {m['rmse_occluded_deg']:.2f} deg, eta occluded/clear "
                    f"{m['mean_trust_occluded']:.2f}/{m['mean_trust_clear']:.2f}"
                    if "rmse_occluded_deg" in m else "")
        pivot = (f", pivot off {m['pivot_error_px_median']:.0f} px"
                 if "pivot_error_px_median" in m else "")
        print(f"  {scenario:18s} settled RMSE {m['rmse_deg_settled']:6.2f} deg, eta "
              f"{m['mean_trust']:.2f}{occluded}{pivot}")
    comparison = {}
    if args.compare:
        before = json.loads(args.compare.read_text())["rows"]
        print(f"against {args.compare}, clip by clip:")
        for scenario in args.scenarios:
            c = comparison[scenario] = compare(rows, before, scenario)
            low, high = c["interval"]
            largest = ", ".join(f"{seed}: {old:.1f} -> {new:.1f}"
                                for seed, old, new in c["largest"]) or "none"
            print(f"  {scenario:18s} {c['before']:6.2f} -> {c['after']:6.2f} deg, change "
                  f"{c['change']:+.2f} (95% {low:+.2f} to {high:+.2f}), {c['better']} of "
                  f"{c['clips']} clips better, {c['worse']} worse; largest {largest}")
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps({"params": params, "pivot_given": args.pivot_given,
                                         "modality": args.modality,
                                         "preset": preset,
                                         "seeds": [first, end], "machine": machine(),
                                         "results": results, "rows": rows,
                                         **({"compare": {"against": str(args.compare),
                                                         **comparison}}
                                            if comparison else {})}, indent=2) + "\n")


if __name__ == "__main__":
    main()
