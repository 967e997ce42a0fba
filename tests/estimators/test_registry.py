"""The estimator registry: one `register` call makes an estimator reachable from the env
wrapper, `imimic eval` and `imimic mimic`."""

import csv
import json
import math

import gymnasium as gym
import numpy as np
import pytest

from imimic_gym.cli import main
from imimic_gym.estimators.registry import (
    ESTIMATORS,
    EstimatorEntry,
    UnsupportedClipError,
    build_estimator,
    get_estimator,
    register,
    unregister,
)
from imimic_gym.estimators.types import Estimate, EstimatorContext
from imimic_gym.wrappers import RegistryObservation, estimate_fields, estimator_context

TOY_ANGLE = 0.25  # rad


class ToyEstimator:
    """Reads nothing: the angle TOY_ANGLE from its reference, and how many frames it saw."""

    def __init__(self, context: EstimatorContext, offset: float = 0.0) -> None:
        self.n, self.offset, self.frames = context.n_links, offset, 0

    def reset(self) -> None:
        self.frames = 0

    def update(self, frame: np.ndarray) -> Estimate:
        self.frames += 1
        zeros = np.zeros(self.n)
        return Estimate(angles=np.full(self.n, TOY_ANGLE + self.offset), omega=zeros,
                        alpha=zeros, torque=zeros, trust=1.0)


@pytest.fixture
def toy():
    entry = register(EstimatorEntry("toy", "a toy that reads nothing", ToyEstimator,
                                    params=("offset",)))
    yield entry
    unregister("toy")


def test_a_toy_estimator_runs_through_the_env_wrapper(toy) -> None:
    env = RegistryObservation(
        gym.make("ImitateVideo-v0", scenario="exp2-servo", n_frames=20), "toy",
        keep_frame=False, offset=0.5)
    obs, _ = env.reset(seed=0)
    for _ in range(5):
        obs, *_ = env.step(np.zeros(1, dtype=np.float32))
    assert obs["estimate"][estimate_fields(1)["angles"]] == pytest.approx([0.75])
    assert env.estimator.frames == 6
    # Rebuilt from its spec by name and parameters: a new estimator, the same settings.
    rebuilt = gym.make(env.spec)
    assert isinstance(rebuilt.estimator, ToyEstimator) and rebuilt.estimator is not env.estimator
    assert rebuilt.estimator.offset == 0.5
    rebuilt.close()
    env.close()


def test_a_toy_estimator_runs_through_imimic_eval(toy, tmp_path) -> None:
    from imimic_gym.clips.cache import load_clip
    from imimic_gym.clips.scenarios import get_scenario
    from imimic_gym.metrics import angle_rmse_deg

    out = tmp_path / "eval.json"
    assert main(["eval", "--scenario", "exp2-servo", "--estimator", "toy", "--episodes", "1",
                 "--first-seed", "3", "--json", str(out)]) == 0
    row = json.loads(out.read_text())[0]["rows"][0]
    truth = load_clip(get_scenario("exp2-servo", seed=3), progress=False).truth.angles
    assert row["rmse_deg"] == pytest.approx(angle_rmse_deg(np.full_like(truth, TOY_ANGLE),
                                                           truth))


def test_a_toy_estimator_runs_through_imimic_mimic(toy, servo_mp4, tmp_path) -> None:
    out = tmp_path / "mimic"
    assert main(["mimic", "--video", str(servo_mp4), "--estimator", "toy",
                 "--out", str(out)]) == 0
    with open(out / "mimic.csv", newline="") as f:
        angles = [float(row["angle_rad"]) for row in csv.DictReader(f)]
    assert len(angles) == 90 and set(angles) == {TOY_ANGLE}


def test_every_entry_says_what_it_follows() -> None:
    context = EstimatorContext(fps=30.0, link_parents=(-1, 0), joint_ranges=((-1, 1),) * 2,
                               reference_direction=-math.pi / 2, demonstrator="servo")
    assert {"don", "don-paper", "cnn", "mog2", "camshift", "oracle"} <= set(ESTIMATORS)
    assert get_estimator("don").unsupported(context) is None
    with pytest.raises(UnsupportedClipError, match="'mog2' follows one moving link; this "
                                                   "clip has 2"):
        build_estimator("mog2", context)
    with pytest.raises(UnsupportedClipError, match="'servo' demonstrator"):
        build_estimator("cnn", context)
    with pytest.raises(UnsupportedClipError, match="reads the clip's truth; this clip has none"):
        build_estimator("oracle", context)
    with pytest.raises(ValueError, match="'camshift' does not take pivot"):
        build_estimator("camshift", EstimatorContext(30.0, (-1,), ((-1, 1),), 0.0), pivot=(1, 2))
    with pytest.raises(ValueError, match="unknown estimator 'sonar'; expected one of"):
        get_estimator("sonar")
    with pytest.raises(ValueError, match="'don' is registered already"):
        register(EstimatorEntry("don", "again", ToyEstimator))


def test_the_env_publishes_its_context() -> None:
    env = gym.make("ImitateVideo-v0", scenario="chain-2", n_frames=12, modality="depth")
    context = estimator_context(env)
    inner = env.unwrapped
    assert context.fps == inner.clip.fps and context.n_links == 2
    assert context.link_parents == (-1, 0) and context.modality == "depth"
    assert context.joint_ranges == tuple(tuple(r) for r in inner.arm.joint_ranges)
    assert context.robot is inner.model
    env.reset(seed=0)
    assert context.truth is not None
    assert np.array_equal(context.truth().angles, inner.clip.truth.angles[0])
    env.close()
    with pytest.raises(ValueError, match="fps must be a positive number"):
        EstimatorContext(fps=0.0, link_parents=(-1,), joint_ranges=((0, 1),),
                         reference_direction=0.0)
