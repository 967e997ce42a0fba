"""The test pool: clips no choice has touched, and how suites sweep it.

Development (every choice: a threshold, a kernel, a policy seed) uses clip seeds 0-899,
the tracker's validation 900-999. The headline figures come from `TEST_POOL` alone,
run once; docs/decisions/evaluation-protocol.md lists the seeds already used up.
"""

from __future__ import annotations

import atexit
import shutil
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

from imimic_gym.metrics import with_interval
from imimic_gym.sweep import Cell, run_sweep, summaries

TEST_POOL = tuple(range(40_000, 40_030))
QUICK_SEEDS = (0, 1)  # a quick run checks a suite works, on development clips
WORST = 3
RESULTS = Path(__file__).resolve().parents[1] / "results"


def work_folder(prefix: str) -> Path:
    """A new folder in the system's temporary folder for a suite's files (1080p copies,
    mimic outputs, labels), deleted when the benchmark process ends."""
    folder = Path(tempfile.mkdtemp(prefix=prefix))
    atexit.register(shutil.rmtree, folder, True)
    return folder


def sweep(name: str, cells: list[Cell], args: Any) -> list[dict[str, Any]]:
    """Run ``cells`` (`sweep.run_sweep`, on ``args.backend``), journalled in
    ``results/<name>.cells.jsonl`` so an interrupted suite resumes (``--resume``), and
    return their summaries per configuration. Raises if a cell failed."""
    journal = RESULTS / f"{name}.cells.jsonl"
    resume = bool(getattr(args, "resume", False))
    if journal.exists() and not resume:
        journal.unlink()
    outcome = run_sweep(cells, journal=journal, resume=resume,
                        backend=getattr(args, "backend", "local"),
                        address=getattr(args, "address", None))
    if outcome.failures:
        raise RuntimeError("cells failed: " + "; ".join(
            f"{cell.name}: {error}" for cell, error in outcome.failures.items()))
    return summaries(cells, outcome.rows)


def spread(rows: list[dict[str, Any]], key: str) -> dict[str, Any]:
    """Mean of ``key`` over the clips with its 95% bootstrap interval, the median, and the
    worst clips (seed, value)."""
    values = np.array([r[key] for r in rows], dtype=np.float64)
    order = np.argsort(-values)[:WORST]
    return {**with_interval(values), "median": float(np.median(values)),
            "worst": [[int(rows[i]["seed"]), float(values[i])] for i in order]}


def ci(cell: dict[str, Any] | None, digits: int = 1) -> str:
    """"mean (low-high)" of a `spread` or `metrics.with_interval` cell."""
    if not cell or cell.get("value") is None:
        return "-"
    dash = " to " if cell["low"] < 0 else "-"  # "-1.5 (-2.6 to -0.4)", not "-2.6--0.4"
    return (f"{cell['value']:.{digits}f} ({cell['low']:.{digits}f}{dash}"
            f"{cell['high']:.{digits}f})")


def worst(cell: dict[str, Any], digits: int = 1) -> str:
    return ", ".join(f"{seed}: {value:.{digits}f}" for seed, value in cell["worst"])


def table(head: list[str], rows: list[list[str]]) -> str:
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    return "\n".join(lines + ["| " + " | ".join(row) + " |" for row in rows])


def pool_text(data: dict[str, Any]) -> str:
    m = data["machine"]
    seeds = data["seeds"]
    pool = ("development clips, to check the suite runs" if data.get("quick") else
            "the test pool: no choice was made on them (docs/decisions/evaluation-protocol.md)")
    return (f"Clip seeds {seeds[0]}-{seeds[-1]} ({len(seeds)} clips a scenario), {pool}. "
            f"Machine: {m['cpu']}, {m['cores']} cores. Means over clips with 95% percentile "
            "bootstrap intervals (2000 resamples, seed 0) and the worst clips (seed: value).")
