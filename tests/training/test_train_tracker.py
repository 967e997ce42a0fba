import importlib.util
import json
import subprocess
import sys
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import pytest

import imimic_gym  # noqa: F401
from imimic_gym.clips.scenarios import scenario_names
from imimic_gym.controllers import PositionController
from imimic_gym.controllers.learned import LearnedController
from imimic_gym.rollout import run_episode
from imimic_gym.wrappers import DONObservation, RegistryObservation

from . import option_helps, refused

SCRIPT = Path(__file__).resolve().parents[2] / "training" / "train_tracker.py"
TINY = ["--scenarios", "exp2-servo", "--train-seeds", "1", "--val-seeds", "900", "--frames",
        "20", "--total-timesteps", "40", "--learning-starts", "20", "--batch-size", "16",
        "--eval-every", "20"]


def script_module(monkeypatch: pytest.MonkeyPatch):
    """The script as a module, registered under its name while the test runs (its dataclass
    and its --help look themselves up there)."""
    spec = importlib.util.spec_from_file_location("train_tracker", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    monkeypatch.setitem(sys.modules, "train_tracker", module)
    spec.loader.exec_module(module)
    return module


def test_a_tiny_training_run_writes_a_policy_that_loads_and_tracks(tmp_path) -> None:
    out = tmp_path / "tiny.pt"
    subprocess.run([sys.executable, str(SCRIPT), "--scenarios", "exp2-servo", "default",
                    "--train-seeds", "1", "--val-seeds", "900", "--frames", "20",
                    "--total-timesteps", "80", "--learning-starts", "40", "--batch-size", "16",
                    "--eval-every", "40", "--out", str(out), "--logdir", str(tmp_path / "runs")],
                   check=True, timeout=300)
    meta = json.loads(out.with_suffix(".json").read_text())
    assert meta["algorithm"] == "sac" and meta["estimator"] == "don"
    assert meta["scenarios"] == ["exp2-servo", "default"]
    assert meta["train_seeds"] == [0] and meta["val_seeds"] == [900]
    assert meta["total_timesteps"] == 80
    assert all(np.isfinite(v) for v in meta["val_metrics"].values())
    assert set(meta["val_metrics"]) == {f"{s}/{c}_rmse_deg" for s in ("exp2-servo", "default")
                                        for c in ("learned", "scripted")}
    assert list((tmp_path / "runs").iterdir())  # TensorBoard events

    assert meta["control"] == "velocity" and meta["rate_history_frames"] == 12
    assert meta["residual_joints"] == ["q1"] and meta["action_size"] == 1  # every joint
    env = DONObservation(gym.make("ImitateVideo-v0", scenario="exp2-servo", n_frames=20,
                                  control="velocity", clip_seeds=(900,)), keep_frame=False)
    metrics = run_episode(env, LearnedController(env, out), seed=0).metrics()
    # 80 steps teach nothing, and the residual is bounded: it stays near the servo; measured
    # 4.3 deg on clip seed 900 (issue 40: about 2x).
    assert np.isfinite(metrics["rmse_deg"]) and metrics["rmse_deg"] < 9.0


def test_a_tiny_3d_run_writes_a_policy_that_drives_the_so101(tmp_path) -> None:
    out = tmp_path / "tiny3d.pt"
    subprocess.run([sys.executable, str(SCRIPT), "--env", "ImitateVideo3D-v0", "--scenarios",
                    "spatial-wave", "--train-seeds", "1", "--val-seeds", "900", "--frames", "12",
                    "--total-timesteps", "48", "--learning-starts", "24", "--batch-size", "16",
                    "--eval-every", "48", "--out", str(out), "--logdir", str(tmp_path / "runs")],
                   check=True, timeout=300)
    meta = json.loads(out.with_suffix(".json").read_text())
    # The 3-D defaults: the oracle's estimate under the position controller, features of
    # the six joints, a residual on the four that point the arm.
    assert (meta["env"], meta["estimator"], meta["control"]) == ("ImitateVideo3D-v0", "oracle",
                                                                 "position")
    assert meta["observation_size"] == (8 + 6 + 12) * 6 + 3 + 12
    assert meta["residual_joints"] == ["shoulder_pan", "shoulder_lift", "elbow_flex",
                                       "wrist_flex"] and meta["action_size"] == 4
    assert set(meta["val_metrics"]) == {"spatial-wave/learned_rmse_deg",
                                        "spatial-wave/scripted_rmse_deg"}
    env = RegistryObservation(gym.make("ImitateVideo3D-v0", scenario="spatial-wave",
                                       n_frames=12, clip_seeds=(900,)), "oracle",
                              keep_frame=False)
    learned, scripted = LearnedController(env, out), PositionController(env)
    obs, _ = env.reset(seed=0)
    learned.reset()
    scripted.reset()
    for _ in range(11):  # wrist_roll and the gripper: the scripted action, bit for bit
        action = learned(obs)
        np.testing.assert_array_equal(action[4:], scripted(obs)[4:])
        obs, reward, *_ = env.step(action)
        assert np.isfinite(reward)


def test_the_script_refuses_held_out_seeds() -> None:
    result = subprocess.run([sys.executable, str(SCRIPT), "--val-seeds", "1000"],
                            capture_output=True, text=True, timeout=60)
    assert result.returncode == 2
    assert "below 1000" in result.stderr


def test_ppo_is_selectable_and_its_policy_loads(tmp_path) -> None:
    out = tmp_path / "ppo.pt"
    subprocess.run([sys.executable, str(SCRIPT), "--algorithm", "ppo", "--control", "position",
                    "--scenarios",
                    "exp2-servo", "--train-seeds", "1", "--val-seeds", "900", "--frames", "20",
                    "--total-timesteps", "100", "--batch-size", "64", "--eval-every", "100",
                    "--out", str(out), "--logdir", str(tmp_path / "runs")],
                   check=True, timeout=300)
    meta = json.loads(out.with_suffix(".json").read_text())
    assert meta["algorithm"] == "ppo"
    assert meta["total_timesteps"] == 512  # one PPO rollout of 512 steps on one env
    env = DONObservation(gym.make("ImitateVideo-v0", scenario="exp2-servo", n_frames=20,
                                  clip_seeds=(900,)), keep_frame=False)
    metrics = run_episode(env, LearnedController(env, out), seed=0).metrics()
    # measured 8.4 deg on clip seed 900 (issue 40: about 2x)
    assert np.isfinite(metrics["rmse_deg"]) and metrics["rmse_deg"] < 17.0


def test_no_timesteps_is_refused_and_a_smoke_run_leaves_the_shipped_policy_alone(
        tmp_path) -> None:
    import hashlib

    from imimic_gym.checkpoints import SHIPPED_CHECKPOINTS

    result = subprocess.run([sys.executable, str(SCRIPT), "--total-timesteps", "0",
                             "--logdir", str(tmp_path / "none")],
                            capture_output=True, text=True, timeout=60)
    assert result.returncode == 2 and "--total-timesteps must be at least 1" in result.stderr
    assert not (tmp_path / "none").exists() or not list((tmp_path / "none").rglob("*.pt"))

    shipped = SHIPPED_CHECKPOINTS / "tracker.pt"
    before = hashlib.sha256(shipped.read_bytes()).hexdigest()
    subprocess.run([sys.executable, str(SCRIPT), "--scenarios", "exp2-servo",
                    "--train-seeds", "1", "--val-seeds", "900", "--frames", "20",
                    "--total-timesteps", "40", "--learning-starts", "20", "--batch-size", "16",
                    "--eval-every", "40", "--logdir", str(tmp_path / "runs"),
                    "--run-name", "smoke"], check=True, timeout=300, cwd=tmp_path)
    assert (tmp_path / "runs" / "smoke" / "tracker.pt").is_file()
    assert hashlib.sha256(shipped.read_bytes()).hexdigest() == before


def test_an_out_that_cannot_be_written_is_said_before_training(tmp_path) -> None:
    (tmp_path / "file").write_text("")
    result = subprocess.run([sys.executable, str(SCRIPT), "--out",
                             str(tmp_path / "file" / "tracker.pt"), "--logdir",
                             str(tmp_path / "runs")],
                            capture_output=True, text=True, timeout=60)
    assert result.returncode == 2 and "Traceback" not in result.stderr
    assert "cannot write --out" in result.stderr


def two_trial_search(tmp_path: Path, out: Path, backend: str, **run: Any) -> dict[str, Any]:
    """A tiny ``--search seed=0,1`` on ``backend`` writing the best policy to ``out``
    (runs under ``tmp_path/runs``); its metadata."""
    subprocess.run([sys.executable, str(SCRIPT), "--scenarios", "exp2-servo",
                    "--train-seeds", "1", "--val-seeds", "900", "--frames", "20",
                    "--total-timesteps", "60", "--learning-starts", "30", "--batch-size", "16",
                    "--eval-every", "60", "--search", "seed=0,1", "--backend", backend,
                    "--run-name", "search", "--logdir", str(tmp_path / "runs"),
                    "--out", str(out)], check=True, timeout=600, **run)
    return dict(json.loads(out.with_suffix(".json").read_text()))


def test_a_two_trial_tune_search_writes_the_best_policy_and_it_loads(tmp_path) -> None:
    """Two Ray Tune trials (seeds 0 and 1) on a local Ray; the one with the lower
    validation RMSE is written to --out, in the format LearnedController loads."""
    out = tmp_path / "best.pt"
    meta = two_trial_search(tmp_path, out, "ray")
    trials = meta["search"]["trials"]
    assert [t["options"] for t in trials] == [{"seed": 0}, {"seed": 1}]
    assert all(np.isfinite(t["val_rmse_deg"]) for t in trials)
    best = min(trials, key=lambda t: t["val_rmse_deg"])
    assert meta["search"]["chosen"] == best["trial"] and meta["search"]["backend"] == "ray"
    assert meta["args"]["seed"] == best["options"]["seed"]
    for trial in trials:  # each trial logs to TensorBoard as a single run does
        assert list((tmp_path / "runs" / "search" / trial["trial"]).glob("events.out.*"))
    env = DONObservation(gym.make("ImitateVideo-v0", scenario="exp2-servo", n_frames=20,
                                  control="velocity", clip_seeds=(900,)), keep_frame=False)
    metrics = run_episode(env, LearnedController(env, out), seed=0).metrics()
    assert np.isfinite(metrics["rmse_deg"])


def test_a_malformed_search_is_refused_before_training(tmp_path) -> None:
    for entry, message in (("colour=red,blue", "KEY one of"),
                           ("learning_rate=fast", "values must be float")):
        result = subprocess.run([sys.executable, str(SCRIPT), "--search", entry,
                                 "--logdir", str(tmp_path)], capture_output=True, text=True,
                                timeout=60)
        assert result.returncode == 2 and message in result.stderr
        assert not list(tmp_path.rglob("*.pt"))


def test_a_search_over_a_list_option_gives_each_trial_one_value(monkeypatch) -> None:
    """``--search val_seeds=900,901`` (a tuple option): two trials, one seed each, passed
    on to each trial's command line as a list flag."""
    module = script_module(monkeypatch)
    args = module.Args(search=("val_seeds=900,901", "seed=0,1"))
    grid = module.search_grid(args)
    assert grid == [{"val_seeds": (900,), "seed": 0}, {"val_seeds": (900,), "seed": 1},
                    {"val_seeds": (901,), "seed": 0}, {"val_seeds": (901,), "seed": 1}]
    argv = module.trial_argv(args, grid[3], Path("/tmp/run/trial_3"))
    at = argv.index("--val-seeds")
    assert argv[at + 1] == "901" and argv[at + 2].startswith("--")
    assert argv[argv.index("--seed") + 1] == "1"


@pytest.mark.parametrize(("flags", "message"), [
    (["--scenarios", "exp2-servo", "nope"], "argument --scenarios: invalid choice: 'nope'"),
    (["--search", "scenarios=default,nope"], "argument --scenarios: invalid choice: 'nope'"),
    (["--scenarios", "exp2-servo", "chain-2"], "exp2-servo has 1, chain-2 has 2 moving links"),
    (["--env", "ImitateVideo3D-v0", "--scenarios", "exp2-servo"],
     "--scenarios: planar scenarios on ImitateVideo3D-v0, which takes spatial ones: "
     "['exp2-servo']"),
    (["--scenarios", "spatial-cup"],
     "--scenarios: spatial scenarios on ImitateVideo-v0: ['spatial-cup']; train them with "
     "--env ImitateVideo3D-v0"),
    (["--env", "ImitateVideo3D-v0", "--control", "velocity"],
     "--control: the SO-101's servos take target angles: ImitateVideo3D-v0 takes position"),
    (["--env", "ImitateVideo3D-v0", "--estimator", "don"],
     "--estimator: estimator 'don' gives planar joint angles; this clip's arm moves in 3-D"),
])
def test_an_unknown_or_mismatched_scenario_is_named_before_any_work(
        tmp_path, flags: list[str], message: str) -> None:
    result = subprocess.run([sys.executable, str(SCRIPT), *flags, "--logdir",
                             str(tmp_path / "runs")], cwd=tmp_path, capture_output=True,
                            text=True, timeout=60)
    assert result.returncode == 2 and "Traceback" not in result.stderr
    said = result.stderr.strip().splitlines()[-1]
    assert message in said
    if "invalid choice" in said:  # and the names it could have been
        assert all(repr(name) in said for name in scenario_names())
    assert not (tmp_path / "runs").exists()


@pytest.mark.parametrize(("flags", "message"), [
    (["--frames", "1"], "argument --frames: expected a whole number of at least 2"),
    (["--batch-size", "0"], "argument --batch-size: expected a whole number of at least 1"),
    (["--gamma", "1.5"], "argument --gamma: expected a number from 0 to 1"),
    (["--learning-rate", "0"], "argument --learning-rate: expected a finite number above 0"),
    (["--net-arch", "128", "0"], "argument --net-arch: expected a whole number of at least 1"),
    (["--train-seeds", "0"], "argument --train-seeds: expected a whole number of at least 1"),
    (["--train-seeds", "48", "--val-seeds", "10"], "training seeds below the validation"),
    (["--algorithm", "dqn"], "argument --algorithm: invalid choice: 'dqn'"),
    (["--env", "ImitateVideo3D-v0", "--residual-joints", "wrist_flex", "elbow"],
     "--residual-joints: distinct joints of the ImitateVideo3D-v0 arm ('shoulder_pan', "
     "'shoulder_lift', 'elbow_flex', 'wrist_flex', 'wrist_roll', 'gripper'), got "
     "['wrist_flex', 'elbow']"),
    (["--residual-joints", "q1", "q1"],
     "--residual-joints: distinct joints of the ImitateVideo-v0 arm ('q1',), got ['q1', 'q1']"),
    (["--search", "gamma=0.9,2"], "argument --gamma: expected a number from 0 to 1"),
])
def test_a_bad_option_is_one_line_before_a_run_folder_exists(tmp_path, flags: list[str],
                                                             message: str) -> None:
    assert message in refused(SCRIPT, [*flags, "--logdir", "runs"], tmp_path)


@pytest.mark.parametrize(("stopped_in", "kept"), [("reward_scales", False), ("evaluate", True)])
def test_a_stopped_run_leaves_no_empty_folder_but_keeps_its_logs(
        tmp_path, monkeypatch, stopped_in: str, kept: bool) -> None:
    """Ctrl-C before training (while the scripted controller's errors are measured) and
    during it (at the first periodic evaluation, 20 steps in)."""
    module = script_module(monkeypatch)

    def interrupt(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(module, stopped_in, interrupt)
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(sys, "argv", ["train_tracker.py", *TINY, "--run-name", "stopped"])
    with pytest.raises(KeyboardInterrupt):
        module.main()
    run = tmp_path / "runs" / "stopped"
    assert not (run / "tracker.pt").exists()
    if kept:
        assert list(run.glob("events.out.tfevents.*"))
    else:
        assert not (tmp_path / "runs").exists()


def test_help_gives_every_option_its_default_and_units() -> None:
    helps = option_helps(SCRIPT)
    assert [flag for flag, text in helps.items() if "default" not in text] == []
    assert "env steps" in helps["--total-timesteps"] and "(default: 160000)" in helps[
        "--total-timesteps"]
    assert "(default: 900 901)" in helps["--val-seeds"]
    assert "(default: 128 128)" in helps["--net-arch"] and "units" in helps["--net-arch"]
    assert "150 frames, 5 s" in helps["--frames"]
    assert "{sac,ppo}" in helps["--algorithm"] and "(default: sac)" in helps["--algorithm"]


def test_a_search_on_ray_without_ray_is_one_line(tmp_path) -> None:
    """Ray not installed (its import fails, as where the ray extra is missing): the
    search says what to install, exit 2, before any trial runs."""
    without_ray = ("import runpy, sys; sys.modules['ray'] = None; "
                   f"sys.argv = [{str(SCRIPT)!r}, *sys.argv[1:]]; "
                   f"runpy.run_path({str(SCRIPT)!r}, run_name='__main__')")
    result = subprocess.run([sys.executable, "-c", without_ray, *TINY, "--search", "seed=0,1",
                             "--backend", "ray", "--logdir", str(tmp_path / "runs"),
                             "--out", str(tmp_path / "best.pt")],
                            capture_output=True, text=True, timeout=120, cwd=tmp_path)
    assert result.returncode == 2 and "Traceback" not in result.stderr, result.stderr[-3000:]
    assert result.stderr.strip().splitlines()[-1].startswith(
        "train_tracker.py: the ray backend needs Ray: pip install")
    assert not list((tmp_path / "runs").glob("*/trial_*/tracker.pt"))


def test_a_two_trial_local_search_writes_the_best_policy_and_it_loads(tmp_path) -> None:
    """``--search seed=0,1 --backend local``: the two trials run one after the other here;
    the one with the lower validation RMSE is copied to --out, bit for bit."""
    out = tmp_path / "best.pt"
    meta = two_trial_search(tmp_path, out, "local", capture_output=True)
    search = meta["search"]
    assert search["backend"] == "local" and search["grid"] == ["seed=0,1"]
    assert [t["options"] for t in search["trials"]] == [{"seed": 0}, {"seed": 1}]
    assert all(np.isfinite(t["val_rmse_deg"]) for t in search["trials"])
    best = min(search["trials"], key=lambda t: t["val_rmse_deg"])
    assert search["chosen"] == best["trial"] and meta["args"]["seed"] == best["options"]["seed"]
    chosen = tmp_path / "runs" / "search" / best["trial"] / "tracker.pt"
    assert out.read_bytes() == chosen.read_bytes()
    env = DONObservation(gym.make("ImitateVideo-v0", scenario="exp2-servo", n_frames=20,
                                  control="velocity", clip_seeds=(900,)), keep_frame=False)
    assert np.isfinite(run_episode(env, LearnedController(env, out), seed=0).metrics()["rmse_deg"])
