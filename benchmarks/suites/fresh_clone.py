"""Suite ``fresh_clone``: what a fresh clone waits for, each from an empty clip cache.

Parts:
- ``paper_eval``: `imimic eval --paper` (every clip it needs is rendered first); limit
  600 s. The package install (`make setup`) is not counted.
- ``cnn_training``: the CNN's default training run, `training/train_cnn.py` with no
  options (its 300 dataset images are regenerated from the annotations first), into a
  temporary folder; limit 10 minutes; and whether its test figures equal those the shipped
  `cnn_arm1.pt` recorded (training is seeded).

Both are wall times on a shared machine: the load average before the run is recorded.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from suites.parts import run_parts

from imimic_gym.checkpoints import SHIPPED_CHECKPOINTS

TRAIN_CNN = Path(__file__).resolve().parents[2] / "training" / "train_cnn.py"
PAPER_LIMIT_S, TRAINING_LIMIT_S = 600, 600


def _timed(command: list[str], cache: str, cwd: str) -> float:
    env = {**os.environ, "IMIMIC_CACHE_DIR": cache, "MUJOCO_GL": "egl"}
    start = time.perf_counter()
    subprocess.run(command, check=True, env=env, cwd=cwd, stdout=subprocess.DEVNULL)
    return time.perf_counter() - start


def paper_eval(args: Any) -> dict[str, Any]:
    imimic = Path(sys.executable).with_name("imimic")
    load = os.getloadavg()[0]
    with tempfile.TemporaryDirectory() as cache, tempfile.TemporaryDirectory() as out:
        seconds = _timed([str(imimic), "eval", "--paper", "--out", out], cache, out)
    return {"command": "imimic eval --paper", "seconds": round(seconds, 1),
            "limit_seconds": PAPER_LIMIT_S, "load_average_before": load}


def cnn_training(args: Any) -> dict[str, Any]:
    load = os.getloadavg()[0]
    with tempfile.TemporaryDirectory() as cache, tempfile.TemporaryDirectory() as work:
        out, report = Path(work) / "cnn_arm1.pt", Path(work) / "run.json"
        seconds = _timed([sys.executable, str(TRAIN_CNN), "--out", str(out), "--json",
                          str(report)], cache, work)
        meta = json.loads(report.read_text())
    shipped = json.loads((SHIPPED_CHECKPOINTS / "cnn_arm1.json").read_text())["test"]
    return {"command": "python training/train_cnn.py", "seconds": round(seconds, 1),
            "train_seconds": meta["train_seconds"], "limit_seconds": TRAINING_LIMIT_S,
            "load_average_before": load, "test": meta["test"],
            "same_test_figures_as_shipped": meta["test"] == shipped}


PARTS = {"paper_eval": paper_eval, "cnn_training": cnn_training}


def run(args: Any) -> dict[str, Any]:
    return run_parts("fresh_clone", PARTS, args)


def _met(ok: bool) -> str:
    return "**met**" if ok else "**missed**"


def render(data: dict[str, Any]) -> str:
    m = data["machine"]
    lines = []
    if "paper_eval" in data:
        p = data["paper_eval"]
        lines.append(f"- `{p['command']}`: {p['seconds']:.0f} s (limit {p['limit_seconds']} s): "
                     f"{_met(p['seconds'] <= p['limit_seconds'])}; load average "
                     f"{p['load_average_before']:.1f} before it.")
    if "cnn_training" in data:
        t = data["cnn_training"]
        refined, alone = t["test"]["cnn_refiner"]["pcp_all"], t["test"]["cnn"]["pcp_all"]
        same = "the same as" if t["same_test_figures_as_shipped"] else "not the same as"
        lines.append(
            f"- `{t['command']}`: {t['seconds']:.0f} s, {t['train_seconds']:.0f} s of it "
            f"training (limit {t['limit_seconds']} s): {_met(t['seconds'] <= t['limit_seconds'])}"
            f"; load average {t['load_average_before']:.1f} before it. CNN + refiner PCP@0.5 "
            f"on the test images {refined['upper']:.3f} / {refined['lower']:.3f} (upper / "
            f"lower arm), the CNN alone {alone['upper']:.3f} / {alone['lower']:.3f}: {same} "
            "the figures the shipped `cnn_arm1.pt` recorded.")
    if not lines:
        return ""
    lines += [f"- part `{part}`: not measured in this JSON (`benchmarks/run.py fresh_clone "
              f"--parts {part}`)." for part in ("paper_eval", "cnn_training") if part not in data]
    return f"""## A fresh clone's waits (suite `fresh_clone`)

Command: `.venv/bin/python benchmarks/run.py fresh_clone` (JSON:
`benchmarks/results/fresh_clone.json`; this section is rendered from it). Each command
from an empty clip cache, wall time, on {m['cpu']}, {m['cores']} cores, shared with other
jobs.

""" + "\n".join(lines) + "\n"
