"""Suite ``accuracy``: every video estimator on the test pool, per scenario (per joint with
several links): what `imimic eval --estimator ...` prints, over `pool.TEST_POOL`.

The figure is the settled angle RMSE (degrees, after the first 0.5 s, when frame
differencing has seen the arm move), with its 95% interval and the worst clips; beside
it the median, the lag and DON's mean trust.
"""

from __future__ import annotations

from typing import Any

from suites.pool import QUICK_SEEDS, TEST_POOL, ci, pool_text, spread, sweep, table, worst

from imimic_gym.bench import machine
from imimic_gym.clips.scenarios import get_scenario
from imimic_gym.sweep import Cell

ONE_LINK = ("exp2-servo", "default", "exp3-forearm-none", "exp3-forearm-low",
            "exp3-forearm-high", "exp1-noisy-fast")
ONE_LINK_ESTIMATORS = ("don", "don-paper", "mog2", "camshift")
LINKED = ("chain-2", "chain-3", "exp4-hand")
LINKED_ESTIMATORS = ("don", "don-paper")


def run(args: Any) -> dict[str, Any]:
    seeds = QUICK_SEEDS if args.quick else TEST_POOL
    cells = [Cell(s, e, None, seed) for s in ONE_LINK for e in ONE_LINK_ESTIMATORS
             for seed in seeds]
    cells += [Cell(s, e, None, seed) for s in LINKED for e in LINKED_ESTIMATORS
              for seed in seeds]
    results = sweep("accuracy" + (".quick" if args.quick else ""), cells, args)
    rows = []
    for result in results:
        n_links = get_scenario(result["scenario"]).n_links
        keys = ["rmse_deg_settled"] + [f"rmse_deg_settled_q{j + 1}" for j in range(n_links)
                                       if n_links > 1]
        rows.append({"scenario": result["scenario"], "estimator": result["estimator"],
                     "n_links": n_links, "clips": result["episodes"],
                     **{key: spread(result["rows"], key) for key in keys},
                     "lag_frames": result["mean"]["lag_frames"],
                     "mean_trust": result["mean"]["mean_trust"], "per_clip": result["rows"]})
    return {"machine": machine(), "quick": bool(args.quick), "seeds": list(seeds),
            "results": rows}


def render(data: dict[str, Any]) -> str:
    quick = "**A quick run (`--quick`): two development clips; not the reported figures.**\n\n" \
        if data.get("quick") else ""
    one = [r for r in data["results"] if r["n_links"] == 1]
    linked = [r for r in data["results"] if r["n_links"] > 1]
    out = [f"""## Estimators on the test pool (suite `accuracy`)

Command: `.venv/bin/python benchmarks/run.py accuracy --backend ray` (JSON:
`benchmarks/results/accuracy.json`; this section is rendered from it). {pool_text(data)}
Each clip is one `imimic eval` cell (`--first-seed {data['seeds'][0]} --episodes
{len(data['seeds'])}`). Settled RMSE: after the first 0.5 s.

{quick}### One link

""" + table(["scenario", "estimator", "settled RMSE (deg)", "median", "worst clips",
             "lag (frames)", "mean eta"],
            [[f"`{r['scenario']}`", r["estimator"], ci(r["rmse_deg_settled"]),
              f"{r['rmse_deg_settled']['median']:.1f}", worst(r["rmse_deg_settled"]),
              f"{r['lag_frames']:.1f}", f"{r['mean_trust']:.2f}"] for r in one])]
    if linked:
        head = ["scenario", "estimator", "joint", "settled RMSE (deg)", "median", "worst clips"]
        lines = []
        for r in linked:
            for j in range(r["n_links"]):
                cell = r[f"rmse_deg_settled_q{j + 1}"]
                lines.append([f"`{r['scenario']}`", r["estimator"], f"q{j + 1}", ci(cell),
                              f"{cell['median']:.1f}", worst(cell)])
        out.append("### Several links (LinkedDON), per joint\n\n" + table(head, lines))
    return "\n\n".join(out) + "\n"
