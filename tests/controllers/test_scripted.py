import gymnasium as gym
import numpy as np
import pytest

import imimic_gym  # noqa: F401
from imimic_gym.controllers import OracleController, PDController, TruthTarget
from imimic_gym.rollout import run_episode


def test_oracle_tracks_the_servo_within_two_degrees() -> None:
    env = gym.make("ImitateVideo-v0", scenario="exp2-servo", clip_seeds=(100, 101))
    for seed in (0, 1):
        metrics = run_episode(env, OracleController(env), seed=seed).metrics()
        assert metrics["rmse_deg"] < 2.0
        assert metrics["lag_frames"] <= 2
        assert metrics["frames"] == 150


@pytest.mark.parametrize("scenario", ["exp2-servo", "chain-2"])
@pytest.mark.parametrize(("control", "bound_deg"), [("position", 2.0), ("velocity", 3.0),
                                                    ("torque", 6.0)])
def test_pd_tracks_the_truth_in_every_control_mode(scenario: str, control: str,
                                                   bound_deg: float) -> None:
    env = gym.make("ImitateVideo-v0", scenario=scenario, control=control, n_frames=90)
    metrics = run_episode(env, PDController(env, TruthTarget(env)), seed=0).metrics()
    assert metrics["rmse_deg"] < bound_deg


def test_pd_on_a_vertical_two_link_arm_fights_gravity() -> None:
    env = gym.make("ImitateVideo-v0", scenario="chain-2", n_frames=90)
    metrics = run_episode(env, OracleController(env), seed=0).metrics()
    assert metrics["rmse_deg"] < 3.0


def test_doing_nothing_is_much_worse_than_the_oracle() -> None:
    env = gym.make("ImitateVideo-v0", scenario="exp2-servo", n_frames=90)
    still = run_episode(env, lambda obs: np.zeros(1, dtype=np.float32), seed=0).metrics()
    oracle = run_episode(env, OracleController(env), seed=0).metrics()
    assert still["rmse_deg"] > 5 * oracle["rmse_deg"]
