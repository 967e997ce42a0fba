import json
import math

import numpy as np
import pytest

from imimic_gym.cli import main
from imimic_gym.evaluation import evaluate_estimator


def test_eval_writes_json_with_finite_metrics(tmp_path) -> None:
    out = tmp_path / "eval.json"
    assert main(["eval", "--scenario", "exp2-servo", "--estimator", "don", "mog2",
                 "--episodes", "1", "--json", str(out)]) == 0
    results = json.loads(out.read_text())
    assert [r["estimator"] for r in results] == ["don", "mog2"]
    for result in results:
        mean = result["mean"]
        for key in ("rmse_deg", "rmse_deg_settled", "lag_frames", "mean_trust"):
            assert math.isfinite(mean[key])
        assert 0.0 <= mean["mean_trust"] <= 1.0
    don = results[0]["mean"]
    # The servo, after warm-up: measured 0.65 deg on seed 1000 (issue 40: about 2x).
    assert don["rmse_deg_settled"] < 1.3


@pytest.mark.parametrize("frames", [2, 15, 16])
def test_a_clip_within_the_warm_up_is_scored_without_settled_figures(frames, tmp_path,
                                                                     capsys) -> None:
    """The warm-up is 15 frames at 30 fps: a clip no longer has RMSE and trust over all
    its frames, and no figures after warm-up (None, not NaN); one frame more has them."""
    out = tmp_path / "short.json"
    assert main(["eval", "--scenario", "exp2-servo", "chain-2", "--episodes", "1",
                 "--frames", str(frames), "--json", str(out)]) == 0

    def refuse(constant: str) -> None:
        raise AssertionError(f"{constant} in the JSON")

    results = json.loads(out.read_text(), parse_constant=refuse)
    within = frames <= 15
    for result in results:
        for scores in (result["mean"], result["rows"][0]):
            assert math.isfinite(scores["rmse_deg"]) and 0 <= scores["mean_trust"] <= 1
            settled = [key for key in scores if key.startswith("rmse_deg_settled")]
            assert len(settled) == (3 if result["scenario"] == "chain-2" else 1)
            for key in [*settled, "lag_frames"]:
                assert (scores[key] is None) if within else math.isfinite(scores[key])
    assert ("end within the 0.5 s warm-up" in capsys.readouterr().out) == within


def test_occluded_frames_are_scored_with_and_without_prediction() -> None:
    result = evaluate_estimator("exp3-forearm-high", "don", episodes=1)
    row = result["rows"][0]
    assert 0 < row["occluded_frames"] < 150
    # Measured on seed 1000: 7.64 deg off, 8.08 on. The prediction layer replaces the
    # readings of the occluded frames, so the two must differ there.
    off, on = row["rmse_occluded_deg_prediction_off"], row["rmse_occluded_deg_prediction_on"]
    assert math.isfinite(off) and math.isfinite(on)
    assert abs(on - off) > 0.2
    assert 0.0 <= row["mean_trust_occluded"] <= 1.0 and 0.0 <= row["mean_trust_clear"] <= 1.0


def test_eval_on_depth_video_scores_the_servo(tmp_path) -> None:
    out = tmp_path / "depth.json"
    assert main(["eval", "--scenario", "exp2-servo", "--estimator", "don", "--episodes", "1",
                 "--modality", "depth", "--json", str(out)]) == 0
    (result,) = json.loads(out.read_text())
    assert result["modality"] == "depth"
    assert result["mean"]["rmse_deg_settled"] < 0.5  # measured 0.22 deg on seed 1000 (issue 40)


def test_eval_refuses_an_unknown_modality() -> None:
    with pytest.raises(ValueError, match="unknown modality 'ir'; expected one of"):
        evaluate_estimator("exp2-servo", "don", episodes=1, modality="ir")


def test_eval_refuses_baselines_on_multi_link_scenarios() -> None:
    with pytest.raises(ValueError, match="follows one moving link; this clip has 2"):
        evaluate_estimator("chain-2", "camshift", episodes=1)


@pytest.mark.parametrize(("scenario", "estimator", "controlled", "why"), [
    ("exp2-servo", "don", False, None),
    ("exp2-servo", "cnn", False, "estimator 'cnn' reads a human demonstrator's arm; this "
                                "clip shows a 'servo' demonstrator"),
    ("chain-3", "mog2", True, "estimator 'mog2' follows one moving link; this clip has 3"),
    ("exp2-servo", "oracle", False, "estimator 'oracle' is the truth itself: score it with "
                                   "a controller"),
    ("chain-3", "oracle", True, None),
])
def test_cannot_score_says_why_before_a_clip_is_rendered(scenario, estimator, controlled,
                                                         why) -> None:
    from imimic_gym.evaluation import cannot_score

    assert cannot_score(scenario, estimator, controlled=controlled) == why


def test_eval_checks_every_estimator_and_scenario_before_running_any(
        tmp_path, capsys, monkeypatch) -> None:
    monkeypatch.setenv("IMIMIC_CACHE_DIR", str(tmp_path / "cache"))
    with pytest.raises(SystemExit) as stop:
        main(["eval", "--scenario", "exp2-servo", "--estimator", "don", "cnn", "--episodes",
              "1", "--frames", "30", "--json", str(tmp_path / "part.json")])
    assert stop.value.code == 2
    printed = capsys.readouterr()
    assert printed.err.strip() == ("imimic eval: 'exp2-servo': estimator 'cnn' reads a human "
                                   "demonstrator's arm; this clip shows a 'servo' "
                                   "demonstrator")
    assert "rmse" not in printed.out  # not even DON's row ran
    assert not (tmp_path / "cache").exists() and not (tmp_path / "part.json").exists()


def test_eval_scores_don_per_joint_on_two_links() -> None:
    result = evaluate_estimator("chain-2", "don", episodes=5, first_seed=7)
    # Tuned on seeds 0-4; clips of 150 frames with the shoulder found from the video. The
    # figure is noisy across seeds (joints 1, 2 measured 7.0, 3.6 deg on seed 7; 3.1-3.4 on
    # seeds 8, 10, 11; 15.1, 9.6 on seed 9), so the median over seeds 7-11 is tested:
    # measured 3.4 and 3.4 deg (issue 40: about 2x).
    for joint in ("q1", "q2"):
        assert np.median([row[f"rmse_deg_settled_{joint}"] for row in result["rows"]]) < 7.0
    for row in result["rows"]:
        assert row["rmse_deg_settled"] == pytest.approx(
            math.sqrt((row["rmse_deg_settled_q1"] ** 2 + row["rmse_deg_settled_q2"] ** 2) / 2))


def test_eval_runs_the_shipped_cnn(tmp_path) -> None:
    out = tmp_path / "eval.json"
    assert main(["eval", "--scenario", "default", "--estimator", "cnn", "--episodes", "1",
                 "--json", str(out)]) == 0
    mean = json.loads(out.read_text())[0]["mean"]
    assert mean["rmse_deg"] < 10.0 and mean["mean_trust"] == 1.0  # measured 4.9 deg, seed 1000


def test_don_paper_is_don_without_its_appearance_layer() -> None:
    """``don-paper`` scores DON's paper layers alone: the same numbers as DON with
    ``appearance=False``, other numbers than the default DON on a cluttered clip."""
    from imimic_gym.clips.cache import load_clip
    from imimic_gym.clips.scenarios import get_scenario
    from imimic_gym.estimators.don.one_link import DON
    from imimic_gym.metrics import angle_rmse_deg

    spec = get_scenario("exp3-forearm-none", seed=1000)
    clip = load_clip(spec, progress=False)
    paper = DON(fps=clip.fps, reference_direction=spec.reference_direction,
                joint_range=spec.joint_ranges[0], appearance=False).run(clip.frames)
    expected = angle_rmse_deg(np.array([e.angles for e in paper]), clip.truth.angles)
    scores = {name: evaluate_estimator("exp3-forearm-none", name, episodes=1)["rows"][0]
              for name in ("don", "don-paper")}
    assert scores["don-paper"]["rmse_deg"] == pytest.approx(expected)
    assert scores["don"]["rmse_deg"] != pytest.approx(expected)


def test_don_paper_on_two_links_is_linked_don_without_its_appearance_layer() -> None:
    from imimic_gym.clips.cache import load_clip
    from imimic_gym.clips.scenarios import get_scenario
    from imimic_gym.estimators.don.linked import LinkedDON
    from imimic_gym.metrics import angle_rmse_deg

    spec = get_scenario("chain-2", seed=1000)
    clip = load_clip(spec, progress=False)
    paper = LinkedDON(spec.link_parents, spec.joint_ranges, fps=clip.fps,
                      reference_direction=spec.reference_direction,
                      appearance=False).run(clip.frames)
    expected = angle_rmse_deg(np.array([e.angles for e in paper]), clip.truth.angles)
    scores = {name: evaluate_estimator("chain-2", name, episodes=1)["rows"][0]
              for name in ("don", "don-paper")}
    assert scores["don-paper"]["rmse_deg"] == pytest.approx(expected)
    assert scores["don"]["rmse_deg"] != pytest.approx(expected)


def test_eval_scores_photos_with_pcp_and_the_elbow_error(tmp_path) -> None:
    import json

    import cv2

    from imimic_gym.cli import main as cli
    from imimic_gym.clips.annotations import ArmAnnotation, write_annotations
    from imimic_gym.clips.cache import load_clip
    from imimic_gym.clips.scenarios import get_scenario

    clip = load_clip(get_scenario("default", seed=5, n_frames=12), progress=False)
    (tmp_path / "images").mkdir()
    arms = []
    for i in (3, 7, 11):
        name = f"frame{i}.png"
        cv2.imwrite(str(tmp_path / "images" / name), cv2.cvtColor(clip.frames[i],
                                                                   cv2.COLOR_RGB2BGR))
        arms.append(ArmAnnotation(name, 320, 240, clip.truth.keypoints[i][:3],
                                  np.ones(3, bool), image_id=i))
    write_annotations(tmp_path / "arms.json", arms)
    out = tmp_path / "photos.json"
    assert cli(["eval", "--photos", str(tmp_path / "arms.json"), "--images",
                str(tmp_path / "images"), "--estimator", "pose", "cnn", "--json",
                str(out)]) == 0
    pose, cnn = json.loads(out.read_text())
    assert pose["photos"] == cnn["photos"] == 3 and cnn["found"] == 3
    for result in (pose, cnn):
        for key in ("pcp_upper", "pcp_lower"):
            cell = result[key]
            assert 0.0 <= cell["low"] <= cell["value"] <= cell["high"] <= 1.0
    # The shipped CNN was trained on renders like these; the pose model reads them too.
    # Measured medians: the CNN 25.5 deg (its bound left at 1.6x), the pose model 1.65
    # (issue 40: about 2x); clip seed 5, frames 3, 7, 11.
    assert cnn["pcp_upper"]["value"] == 1.0 and cnn["elbow_error_deg_median"]["value"] < 40
    assert pose["found"] >= 2 and pose["elbow_error_deg_median"]["value"] < 3.5
    with pytest.raises(SystemExit, match="'don' reads motion between frames"):
        cli(["eval", "--photos", str(tmp_path / "arms.json"), "--images",
             str(tmp_path / "images"), "--estimator", "don"])
    with pytest.raises(SystemExit, match=r"--photos .* and --images .* go together"):
        cli(["eval", "--photos", str(tmp_path / "arms.json")])


def test_eval_on_photos_with_the_pose_model_keeps_stderr_quiet(tmp_path) -> None:
    """MediaPipe's native log lines (two a photo, and more as the model starts) stay off
    stderr unless --verbose asks for them: at most 3 lines in all."""
    import json
    import os
    import subprocess
    import sys

    import cv2

    from imimic_gym.clips.annotations import ArmAnnotation, write_annotations
    from imimic_gym.clips.cache import load_clip
    from imimic_gym.clips.scenarios import get_scenario

    clip = load_clip(get_scenario("default", seed=5, n_frames=12), progress=False)
    (tmp_path / "images").mkdir()
    arms = []
    for i in (2, 5, 8, 11):
        name = f"frame{i}.jpg"
        cv2.imwrite(str(tmp_path / "images" / name),
                    cv2.cvtColor(clip.frames[i], cv2.COLOR_RGB2BGR))
        arms.append(ArmAnnotation(name, 320, 240, clip.truth.keypoints[i][:3],
                                  np.ones(3, bool), image_id=i))
    write_annotations(tmp_path / "arms.json", arms)
    command = [sys.executable, "-m", "imimic_gym.cli", "eval", "--photos",
               str(tmp_path / "arms.json"), "--images", str(tmp_path / "images"),
               "--estimator", "pose", "--json", str(tmp_path / "out.json")]
    runs = {verbose: subprocess.run(command + (["--verbose"] if verbose else []),
                                    capture_output=True, text=True, timeout=300,
                                    env={**os.environ, "MUJOCO_GL": "egl"})
            for verbose in (False, True)}
    for run in runs.values():
        assert run.returncode == 0, run.stderr[-3000:]
    assert json.loads((tmp_path / "out.json").read_text())[0]["photos"] == 4
    quiet, verbose = (len(runs[v].stderr.splitlines()) for v in (False, True))
    assert quiet <= 3, runs[False].stderr
    assert verbose > quiet  # the lines are there, for whoever asks
