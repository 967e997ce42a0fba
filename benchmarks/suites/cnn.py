"""Suite ``cnn``: the shipped CNN + refiner checkpoints (the paper's §4).

Parts:
- ``checkpoints``: each shipped checkpoint scored on its synthetic test split (76 rendered
  images) by `training/train_cnn.py --eval-only`, as a user runs it, with its training run
  as recorded in its metadata; PCP@0.5 on the first 20, 40 and all test images.
- ``clips``: the CNN + refiner and DON on the same rendered clips of the test pool
  (`imimic eval --estimator cnn don`), angle RMSE per clip with intervals, and the paired
  difference CNN - DON.
- ``speed``: CNN + refiner and DON milliseconds per frame on the same frames, one thread,
  alternating runs in one process; the figure is the ratio CNN / DON.
"""

from __future__ import annotations

import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np
from suites.parts import run_parts
from suites.pool import QUICK_SEEDS, TEST_POOL, ci, pool_text, spread, sweep, table, worst

from imimic_gym.checkpoints import SHIPPED_CHECKPOINTS
from imimic_gym.metrics import with_interval
from imimic_gym.sweep import Cell

TRAIN_CNN = Path(__file__).resolve().parents[2] / "training" / "train_cnn.py"
LINKS = (1, 2)
# The paper's PCP@0.5 (upper arm, lower arm) on its 20 test images.
PAPER_20 = {"CNN": [0.40, 0.10], "CNN + refiner": [0.70, 0.35],
            "DeepPose 3rd stage": [0.56, 0.35]}
TARGET_PCP = 0.8  # CNN + refiner on both arms, all test images (issue 4)
CLIP_SCENARIOS = ("exp3-forearm-none",)
CLIP_ESTIMATORS = ("cnn", "don")
SPEED_SCENARIO, SPEED_FRAMES, SPEED_REPEATS = "exp3-forearm-none", 150, 5


def checkpoints(args: Any) -> dict[str, Any]:
    rows = []
    with tempfile.TemporaryDirectory() as work:
        for links in LINKS:
            checkpoint = SHIPPED_CHECKPOINTS / f"cnn_arm{links}.pt"
            out = Path(work) / f"arm{links}.json"
            subprocess.run([sys.executable, str(TRAIN_CNN), "--eval-only", str(checkpoint),
                            "--json", str(out)], check=True, stdout=subprocess.DEVNULL)
            report = json.loads(out.read_text())
            meta = json.loads(checkpoint.with_suffix(".json").read_text())
            rows.append({"links": links, "checkpoint": f"imimic_gym/data/checkpoints/"
                         f"cnn_arm{links}.pt", "training_command": meta["command"],
                         "train_images": meta["train_images"],
                         "train_seconds": meta["train_seconds"],
                         "input_hw": meta["input_hw"],
                         "cnn": report["cnn"], "cnn_refiner": report["cnn_refiner"]})
    return {"command": "python training/train_cnn.py --eval-only "
                       "imimic_gym/data/checkpoints/cnn_arm<links>.pt --json OUT",
            "paper_20": PAPER_20, "target_pcp": TARGET_PCP, "rows": rows}


def clips(args: Any) -> dict[str, Any]:
    seeds = QUICK_SEEDS if args.quick else TEST_POOL
    cells = [Cell(s, e, None, seed) for s in CLIP_SCENARIOS for e in CLIP_ESTIMATORS
             for seed in seeds]
    results = sweep("cnn" + (".quick" if args.quick else ""), cells, args)
    rows = []
    for scenario in CLIP_SCENARIOS:
        by = {r["estimator"]: r for r in results if r["scenario"] == scenario}
        per_seed = {e: {r["seed"]: r for r in by[e]["rows"]} for e in CLIP_ESTIMATORS}
        paired = sorted(set(per_seed["cnn"]) & set(per_seed["don"]))
        rows.append({
            "scenario": scenario,
            **{e: {key: spread(by[e]["rows"], key) for key in ("rmse_deg", "rmse_deg_settled")}
               | {"lag_frames": by[e]["mean"]["lag_frames"]} for e in CLIP_ESTIMATORS},
            "cnn_minus_don_deg": with_interval(
                [per_seed["cnn"][s]["rmse_deg"] - per_seed["don"][s]["rmse_deg"]
                 for s in paired]),
            "per_clip": {e: by[e]["rows"] for e in CLIP_ESTIMATORS}})
    return {"seeds": list(seeds), "rows": rows}


def speed(args: Any) -> dict[str, Any]:
    import cv2
    import torch

    from imimic_gym.clips.cache import load_clip
    from imimic_gym.clips.scenarios import get_scenario
    from imimic_gym.estimators.cnn.estimator import CNNEstimator
    from imimic_gym.estimators.don.one_link import DON

    seed = (QUICK_SEEDS if args.quick else TEST_POOL)[0]
    torch.set_num_threads(1)
    cv2.setNumThreads(1)
    clip = load_clip(get_scenario(SPEED_SCENARIO, seed=seed, n_frames=SPEED_FRAMES),
                     progress=False)
    estimators = {"don": DON(fps=clip.fps), "cnn": CNNEstimator(n_links=1, fps=clip.fps),
                  "cnn_without_refiner": CNNEstimator(n_links=1, fps=clip.fps, refine=False)}
    times: dict[str, list[float]] = {name: [] for name in estimators}
    for _ in range(SPEED_REPEATS):
        for name, estimator in estimators.items():
            start = time.perf_counter()
            estimator.run(clip.frames)
            times[name].append((time.perf_counter() - start) / len(clip.frames) * 1e3)
    ms = {f"{name}_ms": float(np.median(t)) for name, t in times.items()}
    return {"scenario": SPEED_SCENARIO, "seed": seed, "frames": SPEED_FRAMES,
            "repeats": SPEED_REPEATS, "resolution": f"{clip.height}x{clip.width}",
            "threads": 1, **ms, "ratio_cnn_to_don": ms["cnn_ms"] / ms["don_ms"]}


PARTS = {"checkpoints": checkpoints, "clips": clips, "speed": speed}


def run(args: Any) -> dict[str, Any]:
    return run_parts("cnn", PARTS, args)


# The report ---------------------------------------------------------------------------
def _met(ok: bool) -> str:
    return "**met**" if ok else "**missed**"


def _pcp_rows(row: dict[str, Any]) -> list[list[str]]:
    lines = []
    for subset in ("20", "40", "all"):
        for name, key in (("CNN", "cnn"), ("CNN + refiner", "cnn_refiner")):
            r = row[key]
            last = subset == "all"
            lines.append([f"all {r['n_images']}" if last else subset, name,
                          f"{r[f'pcp_{subset}']['upper']:.3f}",
                          f"{r[f'pcp_{subset}']['lower']:.3f}",
                          f"{r['mean_pixel_error']:.1f}" if last else "",
                          f"{r['angle_error_deg']:.1f}" if last else ""])
    return lines


def _checkpoints(part: dict[str, Any]) -> str:
    paper = "; ".join(f"{name} {upper:.2f} / {lower:.2f}"
                      for name, (upper, lower) in part["paper_20"].items())
    out = [f"""### Shipped checkpoints on their test images

Command: `.venv/bin/{part['command']}`. "CNN" is the CNN after its own first stage, as
measured by its training run (the paper's CNN row); pixel errors are at 240x320; the angle
error is the mean absolute joint-angle error. The paper on its 20 images (upper / lower
arm): {paper}. Target: CNN + refiner at least {part['target_pcp']} on both arms on all
test images, and better than the CNN alone.
"""]
    for row in part["rows"]:
        refined, alone = row["cnn_refiner"]["pcp_all"], row["cnn"]["pcp_all"]
        ok = (min(refined.values()) >= part["target_pcp"]
              and refined["lower"] > alone["lower"] and refined["upper"] >= alone["upper"])
        out.append(f"""
`{row['checkpoint']}` ({row['links']} link{'s' * (row['links'] > 1)}), as its metadata
records its training: `{row['training_command']}`, {row['train_images']} images, input
{row['input_hw'][0]}x{row['input_hw'][1]}, {row['train_seconds']:.0f} s.
Target: {_met(ok)}.

""" + table(["test images", "model", "upper arm PCP@0.5", "lower arm PCP@0.5", "px error",
             "angle error (deg)"], _pcp_rows(row)) + "\n")
    return "".join(out)


def _clips(part: dict[str, Any], data: dict[str, Any]) -> str:
    lines = []
    for row in part["rows"]:
        for name in CLIP_ESTIMATORS:
            r = row[name]
            lines.append([f"`{row['scenario']}`", name, ci(r["rmse_deg"], 2),
                          worst(r["rmse_deg"]), ci(r["rmse_deg_settled"], 2),
                          f"{r['lag_frames']:.1f}"])
    diffs = []
    for row in part["rows"]:
        d = row["cnn_minus_don_deg"]
        lower = "the CNN" if d["high"] < 0 else "DON" if d["low"] > 0 else "neither (the " \
            "interval spans 0)"
        diffs.append(f"`{row['scenario']}`: CNN - DON {ci(d, 2)} deg, lower: {lower}")
    return f"""### On rendered clips: `imimic eval --estimator cnn don`

{pool_text({**data, 'seeds': part['seeds']})} RMSE over all frames (the CNN reads each
frame alone and needs no warm-up) and settled (after 0.5 s, when DON has seen the arm
move).

""" + table(["scenario", "estimator", "RMSE (deg)", "worst clips", "settled RMSE (deg)",
             "lag (frames)"], lines) + "\n\nPaired over the same clips, all frames: " + \
        "; ".join(diffs) + ".\n"


def _speed(part: dict[str, Any]) -> str:
    return f"""### Inference time

{part['resolution']} frames of `{part['scenario']}` (seed {part['seed']}), one thread for
torch and OpenCV, median of {part['repeats']} alternating runs of {part['frames']} frames in
one process: DON {part['don_ms']:.2f} ms per frame, CNN + refiner {part['cnn_ms']:.2f} ms
(CNN alone {part['cnn_without_refiner_ms']:.2f} ms): the CNN takes
**{part['ratio_cnn_to_don']:.2f}x** DON's time.
"""


def render(data: dict[str, Any]) -> str:
    quick = "**A quick run (`--quick`): development clips; not the reported figures.**\n\n" \
        if data.get("quick") else ""
    m = data["machine"]
    sections = [f"""## CNN and refiner (suite `cnn`)

Command: `.venv/bin/python benchmarks/run.py cnn` (JSON: `benchmarks/results/cnn.json`;
this section is rendered from it). Machine: {m['cpu']}, {m['cores']} cores.
The CNN on real photos and videos is in the `real` suite's section; how the training set's
size and fine-tuning on real photos were decided, in `docs/decisions/cnn-training-data.md`.

{quick}"""]
    if "checkpoints" in data:
        sections.append(_checkpoints(data["checkpoints"]))
    if "clips" in data:
        sections.append(_clips(data["clips"], data))
    if "speed" in data:
        sections.append(_speed(data["speed"]))
    return "\n".join(sections)
