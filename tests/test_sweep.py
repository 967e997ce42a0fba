"""Sweeps cell by cell (`imimic_gym.sweep`): the same numbers as one process, here and on a
real local Ray; a journal that resumes after a kill; a failing cell retried, then named."""

import json
import os
import signal
import subprocess
import sys

import pytest

from imimic_gym.cli import main
from imimic_gym.evaluation import evaluate_estimator
from imimic_gym.suite import RunConfig, run_config, summarise
from imimic_gym.sweep import Cell, SweepError, read_journal, run_sweep, summaries
from tests.processes import STOP_S, poll_until, stop

FRAMES = 24
SEEDS = (7, 8)


def _cells() -> list[Cell]:
    return ([Cell("exp2-servo", "don", "position", s, FRAMES) for s in SEEDS]
            + [Cell("exp2-servo", "mog2", None, s, FRAMES) for s in SEEDS])


def _in_one_process() -> list[dict]:
    config = RunConfig("exp2-servo", "don", "position", SEEDS, FRAMES)
    return [summarise(config, run_config(config)),
            evaluate_estimator("exp2-servo", "mog2", episodes=2, first_seed=SEEDS[0],
                               frames=FRAMES)]


def test_a_local_sweep_gives_the_numbers_of_one_process(tmp_path) -> None:
    cells = _cells()
    swept = run_sweep(cells, journal=tmp_path / "j.jsonl", progress=False)
    assert not swept.failures and swept.computed == cells
    assert summaries(cells, swept.rows) == _in_one_process()
    # The journal holds every cell, once, with its row as JSON gives it back exactly.
    journal = read_journal(tmp_path / "j.jsonl")
    assert {json.dumps(e["cell"], sort_keys=True) for e in journal.values()} == {
        c.key() for c in cells}
    assert all(e["ok"] and e["attempts"] == 1 and e["seconds"] > 0 for e in journal.values())


def test_a_ray_sweep_gives_the_numbers_of_one_process(local_ray) -> None:
    cells = _cells()[::-1]  # any order: results are grouped and sorted by seed
    swept = run_sweep(cells, backend="ray", progress=False)
    assert not swept.failures
    assert summaries(_cells(), swept.rows) == _in_one_process()


def test_a_failing_cell_is_retried_once_then_named_and_the_others_kept(local_ray,
                                                                       tmp_path) -> None:
    bad = Cell("chain-2", "mog2", "position", 7, FRAMES)  # MOG2 follows one link
    good = _cells()[:2]
    swept = run_sweep([good[0], bad, good[1]], journal=tmp_path / "j.jsonl", backend="ray",
                      progress=False)
    assert set(swept.rows) == set(good)
    assert list(swept.failures) == [bad]
    assert "UnsupportedClipError" in swept.failures[bad] and "one moving link" in \
        swept.failures[bad]
    entry = read_journal(tmp_path / "j.jsonl")[bad.key()]
    assert entry["ok"] is False and entry["attempts"] == 2
    assert entry["name"] == "chain-2/mog2/position/seed 7, 24 frames"
    # Resumed, only the failed cell runs again.
    again = run_sweep([good[0], bad, good[1]], journal=tmp_path / "j.jsonl", resume=True,
                      backend="ray", progress=False)
    assert again.computed == [bad] and set(again.rows) == set(good)


def test_a_killed_sweep_resumes_with_only_the_missing_cells(tmp_path) -> None:
    journal = tmp_path / "sweep.jsonl"
    command = [sys.executable, "-m", "imimic_gym.cli", "eval", "--scenario", "exp2-servo",
               "default", "--estimator", "don", "--controller", "position", "--episodes",
               "4", "--first-seed", "20", "--frames", "60", "--results", str(journal),
               "--out", str(tmp_path / "out")]
    run = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                           env={**os.environ, "MUJOCO_GL": "egl"})
    try:
        poll_until(lambda: journal.exists() and len(journal.read_text().splitlines()) >= 2,
                   run, 300, "two journalled cells")
        run.send_signal(signal.SIGKILL)
        run.wait(timeout=STOP_S)
    finally:
        stop(run)
    before = journal.read_text()
    finished = len(before.splitlines())
    assert 2 <= finished < 8
    with journal.open("a") as f:
        f.write('{"cell": {"scenario": "exp2-ser')  # a line cut short by the kill
    json_out = tmp_path / "resumed.json"
    assert main([*command[3:], "--resume", "--json", str(json_out)]) == 0
    lines = journal.read_text().splitlines()
    assert journal.read_text().startswith(before)
    resumed = [json.loads(line) for line in lines[finished + 1:]]
    assert len(resumed) == 8 - finished  # only the missing cells were computed
    done = {json.dumps(e["cell"], sort_keys=True) for e in read_journal(journal).values()}
    assert len(done) == 8
    results = json.loads(json_out.read_text())
    assert [r["episodes"] for r in results] == [4, 4]
    # The same numbers as an uninterrupted run of the same cells.
    cells = [Cell(s, "don", "position", seed, 60) for s in ("exp2-servo", "default")
             for seed in range(20, 24)]
    assert results == summaries(cells, run_sweep(cells, progress=False).rows)


def test_sweep_inputs_that_cannot_work_are_said(tmp_path, capsys, monkeypatch) -> None:
    journal = tmp_path / "j.jsonl"
    journal.write_text("")
    with pytest.raises(SweepError, match="exists: pass --resume"):
        run_sweep(_cells(), journal=journal, progress=False)
    base = ["eval", "--scenario", "exp2-servo", "--frames", str(FRAMES), "--episodes", "1"]
    for extra, message in (
            (["--resume"], "--resume needs --results"),
            (["--results", str(journal)], "exists: pass --resume"),
            (["--results", str(tmp_path / "k.jsonl"), "--num-envs", "2"], "--num-envs"),
            (["--address", "auto"], "--address is the Ray cluster"),
            (["--scenario", "chain-2", "--estimator", "mog2", "--backend", "ray"],
             "'chain-2': estimator 'mog2' follows one moving link; this clip has 2")):
        with pytest.raises(SystemExit) as exit_:
            main(base + extra)
        assert exit_.value.code == 2
        assert message in capsys.readouterr().err
    monkeypatch.setitem(sys.modules, "ray", None)  # as if the extra were not installed
    with pytest.raises(SystemExit):
        main([*base, "--backend", "ray"])
    assert "pip install '.[ray]' in a clone of imimic_gym" in capsys.readouterr().err
