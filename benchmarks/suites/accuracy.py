"""Suite ``accuracy``: every video estimator on the test pool, per scenario (per joint with
several links): what `imimic eval --estimator ...` prints, over `pool.TEST_POOL`.

The figure is the settled angle RMSE (degrees, after the first 0.5 s, when frame
differencing has seen the arm move), with its 95% interval and the worst clips; beside
it the median, the lag and DON's mean trust. Part ``depth``: DON on the depth video
beside colour, on the same clips.
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


PARTS = ("estimators", "depth")


def run(args: Any) -> dict[str, Any]:
    parts = args.parts or PARTS
    seeds = QUICK_SEEDS if args.quick else TEST_POOL
    data: dict[str, Any] = {"machine": machine(), "quick": bool(args.quick),
                            "seeds": list(seeds)}
    if "estimators" in parts:
        data["results"] = estimators(seeds, args)
    if "depth" in parts:
        data["depth"] = depth(seeds, args)
    return data


def estimators(seeds: tuple[int, ...], args: Any) -> list[dict[str, Any]]:
    """Every video estimator on every scenario, per clip (`imimic eval`'s rows)."""
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
    return rows


def depth(seeds: tuple[int, ...], args: Any) -> list[dict[str, Any]]:
    """DON on the depth video (`imimic eval --modality depth`) beside DON on colour, per
    one-link scenario: settled RMSE and depth minus colour per clip, paired."""
    cells = [Cell(s, "don", None, seed, None, modality) for s in ONE_LINK
             for modality in ("rgb", "depth") for seed in seeds]
    results = sweep("accuracy.depth" + (".quick" if args.quick else ""), cells, args)
    rows = []
    for scenario in ONE_LINK:
        by = {r["modality"]: r for r in results if r["scenario"] == scenario}
        colour, grey = by["rgb"]["rows"], by["depth"]["rows"]
        difference = [{"seed": a["seed"], "gap": b["rmse_deg_settled"] - a["rmse_deg_settled"]}
                      for a, b in zip(colour, grey, strict=True)]
        rows.append({"scenario": scenario, "depth": spread(grey, "rmse_deg_settled"),
                     "rgb": spread(colour, "rmse_deg_settled"),
                     "depth_minus_rgb": spread(difference, "gap")})
    return rows


def render(data: dict[str, Any]) -> str:
    quick = "**A quick run (`--quick`): two development clips; not the reported figures.**\n\n" \
        if data.get("quick") else ""
    one = [r for r in data.get("results", []) if r["n_links"] == 1]
    linked = [r for r in data.get("results", []) if r["n_links"] > 1]
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
    if data.get("depth"):
        out.append("""### DON on depth video

The clip's depth as grey frames, near = bright (`imimic eval --modality depth`, DON's depth
preset: a 7x7 Gaussian), beside colour on the same clips; the gap is depth's settled RMSE
less colour's, per clip, with its interval (positive: depth is worse).

""" + table(["scenario", "depth (deg)", "colour (deg)", "depth - colour (deg)",
             "worst gaps"],
            [[f"`{r['scenario']}`", ci(r["depth"]), ci(r["rgb"]), ci(r["depth_minus_rgb"]),
              worst(r["depth_minus_rgb"])] for r in data["depth"]]))
    return "\n\n".join(out) + "\n"
