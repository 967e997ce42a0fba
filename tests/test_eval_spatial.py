"""`imimic eval` on the spatial scenarios: the 3-D estimators scored per seed against the
rendered 3-D truth, and the SO-101 tracking through the suite."""

import json

import pytest

from imimic_gym.cli import main
from imimic_gym.cli.common import CommandError


def test_spatial_estimators_report_flexion_and_forearm_direction_per_seed(tmp_path) -> None:
    out = tmp_path / "eval.json"
    assert main(["eval", "--scenario", "spatial-curl", "--estimator", "pose3d",
                 "pose3d-depth", "pose-world", "--episodes", "2", "--frames", "30",
                 "--json", str(out)]) == 0
    results = {r["estimator"]: r for r in json.loads(out.read_text())}
    assert set(results) == {"pose3d", "pose3d-depth", "pose-world"}
    for result in results.values():
        assert [row["seed"] for row in result["rows"]] == [1000, 1001]
        for row in result["rows"]:
            assert 0.0 <= row["forearm_direction_error_deg"] <= 180.0
            assert row["elbow_flexion_rmse_deg"] >= 0.0 and row["coverage"] > 0.5
    # The depth image gives the keypoints their depth: measured 2.4 deg of forearm error
    # (mean of 1.6 and 3.2 on seeds 1000, 1001; issue 40: about 2x); the lift 10.8 and
    # MediaPipe's world landmarks 20.9.
    assert results["pose3d-depth"]["mean"]["forearm_direction_error_deg"] < 5.0


def test_planar_estimators_are_refused_on_a_spatial_scenario() -> None:
    with pytest.raises(CommandError, match="gives planar joint angles; this clip's arm moves"):
        main(["eval", "--scenario", "spatial", "--estimator", "don", "--episodes", "1"])


@pytest.mark.parametrize("estimator", ["pose3d", "oracle"])
def test_the_suite_drives_the_so101_on_a_spatial_scenario(estimator, tmp_path) -> None:
    out = tmp_path / "suite.json"
    assert main(["eval", "--scenario", "spatial-raise", "--estimator", estimator,
                 "--controller", "position", "--episodes", "1", "--frames", "30",
                 "--json", str(out), "--out", str(tmp_path / "suite")]) == 0
    (result,) = json.loads(out.read_text())
    # Joint RMSE against the retargeted truth: measured 2.2 deg for the oracle and 13.1 for
    # pose3d on seed 1000 (issue 40: about 2x).
    assert result["mean"]["rmse_deg"] < (4.5 if estimator == "oracle" else 26.0)


@pytest.mark.parametrize(("scenario", "estimator"), [("spatial-reach", "pose3d"),
                                                     ("default", "pose")])
def test_scoring_a_clip_closes_the_pose_models_graph(scenario, estimator,
                                                    monkeypatch: pytest.MonkeyPatch) -> None:
    """A graph left open keeps its native memory (about 100 MB) to the end of the
    process: a sweep scoring clip after clip in one process ran out of memory."""
    from imimic_gym.estimators.pose.model import PoseModel
    from imimic_gym.evaluation import evaluate_clip

    models: list[PoseModel] = []
    start = PoseModel._start

    def started(self: PoseModel) -> None:
        models.append(self)
        start(self)

    monkeypatch.setattr(PoseModel, "_start", started)
    row = evaluate_clip(scenario, estimator, seed=3, frames=12)
    assert row["coverage" if estimator == "pose3d" else "mean_trust"] > 0.0
    assert models and all(model._graph is None for model in models)
