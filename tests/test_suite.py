import json
import math
import os
import subprocess
import sys

import pytest

from imimic_gym.cli import main
from imimic_gym.estimators.registry import ESTIMATORS
from imimic_gym.suite import CONTROLLERS, METRICS, RunConfig, run_config, summarise

TINY = ("--episodes", "1", "--first-seed", "7", "--frames", "40")


def test_eval_suite_writes_json_table_and_plots_with_finite_values(tmp_path, capsys) -> None:
    out, js = tmp_path / "suite", tmp_path / "suite.json"
    assert main(["eval", "--scenario", "exp3-forearm-low", "--estimator", "don", "oracle",
                 "--controller", "position", "velocity", *TINY, "--out", str(out),
                 "--json", str(js)]) == 0
    results = json.loads(js.read_text())
    assert [(r["estimator"], r["controller"]) for r in results] == [
        ("don", "position"), ("oracle", "position"), ("don", "velocity"),
        ("oracle", "velocity")]
    for result in results:
        assert set(result) >= {"scenario", "estimator", "controller", "control", "episodes",
                               "seeds", "mean", "rows"}
        assert result["seeds"] == [7]
        for key in ("rmse_deg", "max_error_deg", "lag_frames", "jerk_deg_s3", "mean_trust"):
            assert math.isfinite(result["mean"][key])
        recovery = result["mean"]["recovery_s"]
        assert recovery is None or math.isfinite(recovery)
    # The true angles beat DON's with the same controller; the oracle's trust is 1.
    assert results[1]["mean"]["rmse_deg"] < results[0]["mean"]["rmse_deg"]
    assert results[1]["mean"]["mean_trust"] == 1.0
    table = (out / "eval.md").read_text()
    assert table.count("| `exp3-forearm-low` |") == 4
    assert table in capsys.readouterr().out
    assert len(list((out / "plots").glob("*.png"))) == 4


def test_vectorised_sweep_gives_the_plain_loops_numbers() -> None:
    config = RunConfig("exp2-servo", "don", "position", seeds=(3, 4, 5), frames=30)
    plain = summarise(config, run_config(config, num_envs=1))
    vector = summarise(config, run_config(config, num_envs=2))
    for a, b in zip(plain["rows"], vector["rows"], strict=True):
        assert a["seed"] == b["seed"]
        assert a["recovery_s"] is b["recovery_s"] is None  # no occluder on the servo
        for key in METRICS:
            if key != "recovery_s":
                assert a[key] == pytest.approx(b[key], rel=1e-9, abs=1e-12)


def test_the_oracle_controller_runs_vectorised_too() -> None:
    config = RunConfig("exp4-hand", "oracle", "oracle", seeds=(3, 4), frames=30)
    rows = summarise(config, run_config(config, num_envs=2))["rows"]
    assert [r["seed"] for r in rows] == [3, 4]
    assert all(r["rmse_deg"] < 2.4 for r in rows)  # measured 1.07, 1.17 deg (issue 40: about 2x)


def test_paper_mode_prints_every_experiment(tmp_path, capsys) -> None:
    assert main(["eval", "--paper", *TINY, "--out", str(tmp_path)]) == 0
    printed = capsys.readouterr().out
    for name in ("exp1", "exp2", "exp3 none", "exp3 low", "exp3 high", "exp4"):
        assert f"| {name} |" in printed
    assert "| exp4 | `exp4-hand` | don |" in printed and "LinkedDON" in printed


def test_registries_refuse_unknown_names() -> None:
    assert {"oracle", "don", "mog2", "camshift"} <= set(ESTIMATORS)
    assert {"oracle", "position", "velocity", "torque", "learned"} <= set(CONTROLLERS)
    with pytest.raises(ValueError, match="unknown estimator 'sonar'; expected one of"):
        RunConfig("exp2-servo", "sonar", "position", seeds=(0,))
    with pytest.raises(ValueError, match="unknown scenario 'mars'"):
        RunConfig("mars", "don", "position", seeds=(0,))


def test_estimator_only_eval_refuses_baselines_on_several_links_by_name() -> None:
    message = "'chain-2': estimator 'mog2' follows one moving link; this clip has 2"
    with pytest.raises(SystemExit, match=message):
        main(["eval", "--scenario", "chain-2", "--estimator", "mog2", "--episodes", "1"])


def test_a_suite_with_nothing_that_can_run_is_refused_by_name(tmp_path, capsys) -> None:
    with pytest.raises(SystemExit) as stop:
        main(["eval", "--scenario", "exp2-servo", "--estimator", "cnn", "--controller",
              "position", *TINY, "--out", str(tmp_path / "out")])
    assert stop.value.code == 2
    assert "nothing to run: exp2-servo/cnn/position cannot run" in capsys.readouterr().err
    assert not (tmp_path / "out" / "eval.md").exists()


def test_a_vectorised_sweep_on_clips_not_yet_rendered_finishes(tmp_path) -> None:
    """Sub-env processes forked by gym.make_vec that each had to render a clip hung; the
    suite renders the clips first. Run in a child process with an empty clip cache, so a
    hang fails the test at the timeout instead of stalling the suite."""
    script = ("from imimic_gym.suite import RunConfig, run_config, summarise\n"
              "config = RunConfig('exp2-servo', 'don', 'position', seeds=(11, 12), frames=20)\n"
              "print([r['seed'] for r in summarise(config, run_config(config, 2))['rows']])\n")
    env = {**os.environ, "IMIMIC_CACHE_DIR": str(tmp_path / "cache")}
    done = subprocess.run([sys.executable, "-c", script], env=env, capture_output=True,
                          text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.strip().endswith("[11, 12]")
