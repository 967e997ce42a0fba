"""Evaluation sweeps cell by cell, here or as Ray tasks (`backends.fan_out`), journalled.

A `Cell` is one (scenario, estimator, controller, seed): with a controller, one episode of
the tracking suite (`suite.run_config` on that seed alone); without one, the estimator
scored on that clip (`evaluation.evaluate_clip`). A cell builds its own env and estimator
from the registries wherever it runs and returns its per-seed row, so a sweep gives the
same numbers as `imimic eval` in one process (the order aside).

The journal is a JSON-lines file, one line per finished cell, written and flushed as
each cell finishes: ``{"cell": {...}, "name": ..., "ok": true, "row": {...}, "attempts":
1, "seconds": ...}``, or ``"ok": false`` with ``"error"``. `run_sweep(..., resume=True)`
computes only the cells without an ``ok`` line (a line cut short by a kill is ignored).
"""

from __future__ import annotations

import json
import os
import time
from collections.abc import Iterable, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from tqdm import tqdm

from imimic_gym.backends import fan_out
from imimic_gym.interrupts import CTRL_C, is_ctrl_c

__all__ = ["Cell", "SweepError", "SweepInterrupted", "SweepResult", "read_journal", "run_cell",
           "run_sweep", "summaries"]


class SweepError(ValueError):
    """A sweep's journal cannot be used as asked (exists without resume, or unreadable)."""


@dataclass(frozen=True)
class Cell:
    """One cell of a sweep. ``controller=None``: the estimator alone on the clip (with
    ``modality``); else one tracking episode (RGB). ``frames``: clip length (None: the
    scenario's). ``trajectory``: also return the episode's time series (for plots)."""

    scenario: str
    estimator: str
    controller: str | None
    seed: int
    frames: int | None = None
    modality: str = "rgb"
    trajectory: bool = field(default=False, compare=False)

    @property
    def name(self) -> str:
        what = self.controller or f"estimate only, {self.modality}"
        length = f", {self.frames} frames" if self.frames else ""
        return f"{self.scenario}/{self.estimator}/{what}/seed {self.seed}{length}"

    def key(self) -> str:
        fields = asdict(self)
        fields.pop("trajectory")
        return json.dumps(fields, sort_keys=True)

    def config_key(self) -> tuple:
        """What its summary groups by: every field but the seed."""
        return (self.scenario, self.estimator, self.controller, self.frames, self.modality)


def run_cell(cell: Cell) -> dict[str, Any]:
    """The cell's row: ``{"seed": ..., metric: value, ...}``, plus ``"trajectory"`` (lists
    of t (s), target and robot angles (rad), reward, occlusion, trust) when asked."""
    if cell.controller is None:
        from imimic_gym.evaluation import evaluate_clip

        return evaluate_clip(cell.scenario, cell.estimator, cell.seed, cell.modality,
                             cell.frames)
    from imimic_gym.rollout import run_episode

    env, controller = _episode_runner(cell)
    episode = run_episode(env, controller, seed=cell.seed, options={"clip_seed": cell.seed})
    row = {"seed": cell.seed, **episode.metrics()}
    if cell.trajectory:
        row["trajectory"] = {
            name: np.asarray(getattr(episode, name)).tolist()
            for name in ("time", "target", "robot", "reward", "occlusion", "trust")}
    return row


# The env and controller of the last configuration this process ran: a worker runs the
# next seed of the same configuration on them, as `suite.run_config` runs its seeds (an
# episode depends on its seed alone), without building the env again.
_RUNNER: dict[tuple, tuple[Any, Any]] = {}


def _episode_runner(cell: Cell) -> tuple[Any, Any]:
    from imimic_gym.suite import CONTROLLERS, RunConfig

    key = cell.config_key()
    if key not in _RUNNER:
        for env, _ in _RUNNER.values():
            env.close()
        _RUNNER.clear()
        config = RunConfig(cell.scenario, cell.estimator, str(cell.controller), (cell.seed,),
                           cell.frames)
        env = config.make_env()
        _RUNNER[key] = (env, CONTROLLERS[config.controller][1](env))
    return _RUNNER[key]


def _timed(cell: Cell) -> dict[str, Any]:
    start = time.perf_counter()
    row = run_cell(cell)
    return {"row": row, "seconds": time.perf_counter() - start, "host": os.uname().nodename}


@dataclass
class SweepResult:
    """Rows of the cells that finished (this run or, resumed, an earlier one), the errors
    of those that failed every attempt, and which cells this run computed."""

    rows: dict[Cell, dict[str, Any]]
    failures: dict[Cell, str]
    computed: list[Cell]


class SweepInterrupted(KeyboardInterrupt):
    """Ctrl-C stopped a sweep: ``result`` holds the cells that had finished (journalled,
    if there is a journal)."""

    def __init__(self, result: SweepResult) -> None:
        super().__init__()
        self.result = result


def read_journal(path: str | Path) -> dict[str, dict[str, Any]]:
    """The journal's last line per cell key (lines that do not parse, such as one cut short
    by a kill, are skipped)."""
    entries: dict[str, dict[str, Any]] = {}
    try:
        text = Path(path).read_text()
    except OSError as error:
        raise SweepError(f"cannot read the sweep journal {path}: {error}") from error
    for line in text.splitlines():
        try:
            entry = json.loads(line)
            entries[json.dumps(entry["cell"], sort_keys=True)] = entry
        except (json.JSONDecodeError, KeyError, TypeError):
            continue
    return entries


def run_sweep(cells: Sequence[Cell], journal: str | Path | None = None, resume: bool = False,
              backend: str = "local", address: str | None = None, retries: int = 1,
              progress: bool = True) -> SweepResult:
    """Run ``cells`` on ``backend`` (a cell that raises is retried ``retries`` times, then
    reported by name), appending each to ``journal`` as it finishes. With ``resume`` the
    cells that already have an ok line in ``journal`` are taken from it, not run. Ctrl-C
    raises `SweepInterrupted` (a KeyboardInterrupt) with the cells that had finished."""
    done: dict[str, dict[str, Any]] = {}
    if journal is not None:
        journal = Path(journal)
        if journal.exists() and not resume:
            raise SweepError(f"the sweep journal {journal} exists: pass --resume to go on "
                             "with it, or name another file")
        if resume and journal.exists():
            done = {k: e for k, e in read_journal(journal).items() if e.get("ok")}
        journal.parent.mkdir(parents=True, exist_ok=True)
    elif resume:
        raise SweepError("resuming needs the journal of the sweep to resume")
    rows = {c: done[c.key()]["row"] for c in cells if c.key() in done}
    pending = [c for c in cells if c.key() not in done]
    result = SweepResult(rows=rows, failures={}, computed=[])
    bar = tqdm(total=len(cells), initial=len(rows), desc=f"sweep ({backend})", unit="cell",
               disable=not progress)
    stream = None
    if journal is not None:
        stream = open(journal, "a")
        if stream.tell() > 0 and not _ends_a_line(journal):
            stream.write("\n")  # the last line was cut short (a kill mid-write): leave it
    try:
        for outcome in fan_out(_timed, pending, backend=backend, address=address,
                               retries=retries):
            cell = outcome.item
            entry: dict[str, Any] = {"cell": json.loads(cell.key()), "name": cell.name,
                                     "ok": outcome.ok, "attempts": outcome.attempts}
            if outcome.ok:
                entry.update(outcome.value)
                result.rows[cell] = outcome.value["row"]
            else:
                entry["error"] = outcome.error
                result.failures[cell] = str(outcome.error)
                bar.write(f"failed after {outcome.attempts} attempts: {cell.name}: "
                          f"{outcome.error}")
            result.computed.append(cell)
            if stream is not None:
                stream.write(json.dumps(entry) + "\n")
                stream.flush()
                os.fsync(stream.fileno())
            bar.update()
    except CTRL_C as error:
        if not is_ctrl_c(error):
            raise
        raise SweepInterrupted(result) from error
    finally:
        bar.close()
        if stream is not None:
            stream.close()
    return result


def _ends_a_line(path: Path) -> bool:
    with open(path, "rb") as f:
        f.seek(-1, os.SEEK_END)
        return f.read(1) == b"\n"


def summaries(cells: Iterable[Cell], rows: dict[Cell, dict[str, Any]]) -> list[dict[str, Any]]:
    """Per (scenario, estimator, controller, frames, modality), in order of first
    appearance, the result `imimic eval` gives for it (`suite.summarise_rows` or
    `evaluation.summarise_estimator`), from the rows of its cells that finished."""
    from imimic_gym.evaluation import summarise_estimator
    from imimic_gym.suite import RunConfig, summarise_rows

    groups: dict[tuple, list[Cell]] = {}
    for cell in cells:
        groups.setdefault(cell.config_key(), []).append(cell)
    out = []
    for group in groups.values():
        finished = sorted((c for c in group if c in rows), key=lambda c: c.seed)
        if not finished:
            continue
        group_rows = [{k: v for k, v in rows[c].items() if k != "trajectory"}
                      for c in finished]
        first = finished[0]
        if first.controller is None:
            out.append(summarise_estimator(first.scenario, first.estimator, first.modality,
                                           group_rows))
        else:
            config = RunConfig(first.scenario, first.estimator, first.controller,
                               tuple(c.seed for c in finished), first.frames)
            out.append(summarise_rows(config, group_rows))
    return out
