"""Suite ``tracking``: estimator + controller on the test pool, as `imimic eval
--estimator don --controller ...` runs it, and the learned tracker's margin.

The figure is the robot's RMS tracking error (degrees, whole clip) per clip. The learned
tracker's margin is 1 - its mean RMSE / the best scripted controller's mean RMSE on the
same clips, with a paired bootstrap interval (clips resampled together); its target,
from the issue that asked for the tracker: at least 20%.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from suites.pool import QUICK_SEEDS, TEST_POOL, ci, pool_text, spread, sweep, table, worst

from imimic_gym.bench import machine
from imimic_gym.metrics import bootstrap_interval
from imimic_gym.sweep import Cell

SCENARIOS = ("exp2-servo", "exp3-forearm-none", "exp3-forearm-low", "exp3-forearm-high")
SCRIPTED = ("position", "velocity", "torque")
CONTROLLERS = ("oracle", *SCRIPTED, "learned")
TARGET_MARGIN = 0.20


def _margin(learned: np.ndarray, scripted: np.ndarray) -> dict[str, Any]:
    def statistic(index: np.ndarray) -> float:
        picked = index.astype(int)
        return float(1 - learned[picked].mean() / scripted[picked].mean())

    index = np.arange(len(learned), dtype=np.float64)
    low, high = bootstrap_interval(index, statistic)
    return {"value": statistic(index), "low": low, "high": high, "n": len(learned)}


def run(args: Any) -> dict[str, Any]:
    seeds = QUICK_SEEDS if args.quick else TEST_POOL
    cells = [Cell(s, "don", c, seed) for s in SCENARIOS for c in CONTROLLERS for seed in seeds]
    results = sweep("tracking" + (".quick" if args.quick else ""), cells, args)
    rows, margins = [], []
    for scenario in SCENARIOS:
        by = {r["controller"]: r for r in results if r["scenario"] == scenario}
        for controller in CONTROLLERS:
            r = by[controller]
            rows.append({"scenario": scenario, "controller": controller,
                         "rmse_deg": spread(r["rows"], "rmse_deg"),
                         "max_error_deg": r["mean"]["max_error_deg"],
                         "lag_frames": r["mean"]["lag_frames"], "per_clip": r["rows"]})
        best = min(SCRIPTED, key=lambda c: by[c]["mean"]["rmse_deg"])
        learned = np.array([r["rmse_deg"] for r in by["learned"]["rows"]])
        scripted = np.array([r["rmse_deg"] for r in by[best]["rows"]])
        margin = _margin(learned, scripted)
        margins.append({"scenario": scenario, "best_scripted": best, "margin": margin,
                        "met": margin["value"] >= TARGET_MARGIN})
    return {"machine": machine(), "quick": bool(args.quick), "seeds": list(seeds),
            "estimator": "don", "target_margin": TARGET_MARGIN, "results": rows,
            "margins": margins}


def render(data: dict[str, Any]) -> str:
    quick = "**A quick run (`--quick`): two development clips; not the reported figures.**\n\n" \
        if data.get("quick") else ""
    target = data["target_margin"]
    return f"""## Tracking on the test pool (suite `tracking`)

Command: `.venv/bin/python benchmarks/run.py tracking --backend ray` (JSON:
`benchmarks/results/tracking.json`; this section is rendered from it). {pool_text(data)}
DON reads the video; each controller drives the robot from its estimate (the oracle from
the true angles one frame ahead: the control loop's bound); `learned` is the shipped
policy. Robot RMS tracking error over the whole clip.

{quick}""" + table(
        ["scenario", "controller", "RMSE (deg)", "median", "worst clips", "max error (deg)",
         "lag (frames)"],
        [[f"`{r['scenario']}`", r["controller"], ci(r["rmse_deg"], 2),
          f"{r['rmse_deg']['median']:.2f}", worst(r["rmse_deg"]),
          f"{r['max_error_deg']:.1f}", f"{r['lag_frames']:.1f}"] for r in data["results"]]) + f"""

The learned tracker against the best scripted controller on the same clips (the one with
the lowest mean there), 1 - learned / scripted, with a paired 95% interval; target: at
least {target:.0%} lower.

""" + table(["scenario", "best scripted", "learned lower by", "target"],
            [[f"`{m['scenario']}`", m["best_scripted"],
              f"{m['margin']['value']:.1%} ({m['margin']['low']:.1%} to "
              f"{m['margin']['high']:.1%})", "**met**" if m["met"] else "**missed**"]
             for m in data["margins"]]) + "\n"
