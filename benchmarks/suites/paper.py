"""Suite ``paper``: the paper's experiments 1-4 on the test pool, our figures beside its
statements (`imimic eval --paper --first-seed 40000 --episodes 30`), each clip a cell."""

from __future__ import annotations

from typing import Any

from suites.pool import QUICK_SEEDS, TEST_POOL, ci, pool_text, spread, sweep, table

from imimic_gym.bench import machine
from imimic_gym.paper import paper_configs, paper_table
from imimic_gym.sweep import Cell


def run(args: Any) -> dict[str, Any]:
    seeds = QUICK_SEEDS if args.quick else TEST_POOL
    configs = paper_configs(tuple(seeds))
    cells = [Cell(c.scenario, c.estimator, c.controller, seed) for c in configs
             for seed in c.seeds]
    results = sweep("paper" + (".quick" if args.quick else ""), cells, args)
    for result in results:
        result["rmse_deg_spread"] = spread(result["rows"], "rmse_deg")
    return {"machine": machine(), "quick": bool(args.quick), "seeds": list(seeds),
            "results": results}


def render(data: dict[str, Any]) -> str:
    quick = "**A quick run (`--quick`): two development clips; not the reported figures.**\n\n" \
        if data.get("quick") else ""
    spreads = table(["scenario", "controller", "RMSE (deg)", "worst clips"], [
        [f"`{r['scenario']}`", r["controller"], ci(r["rmse_deg_spread"], 2),
         ", ".join(f"{s}: {v:.1f}" for s, v in r["rmse_deg_spread"]["worst"])]
        for r in data["results"]])
    return f"""## The paper's experiments on the test pool (suite `paper`)

Command: `.venv/bin/python benchmarks/run.py paper --backend ray` (JSON:
`benchmarks/results/paper.json`; this section is rendered from it). {pool_text(data)}
DON reads the video and drives the robot through the paper's servo (position) or the
learned tracker; the paper gives no angle errors, only the statements in its column, so
the "here" column is the verdict against them, computed.

{quick}{paper_table(data["results"])}

The RMSE above with its interval and worst clips:

{spreads}
"""
