import gymnasium as gym
import numpy as np
import pytest

import imimic_gym  # noqa: F401
from imimic_gym.controllers import EstimateTarget, PDController
from imimic_gym.rollout import run_episode
from imimic_gym.wrappers import CNNObservation, estimate_fields


def test_cnn_observation_drives_the_robot_after_the_arm() -> None:
    env = CNNObservation(gym.make("ImitateVideo-v0", scenario="chain-2", clip_seeds=(7,),
                                  n_frames=45), keep_frame=False)
    obs, _ = env.reset(seed=0)
    assert obs["estimate"].shape == (10,) and obs["estimate"].dtype == np.float32
    fields = estimate_fields(2)
    assert np.all(np.isfinite(obs["estimate"])) and obs["estimate"][fields["trust"]] == 1.0
    trajectory = run_episode(env, PDController(env, EstimateTarget(env)), seed=0)
    assert trajectory.metrics()["rmse_deg"] < 20.0


def test_cnn_observation_refuses_the_servo() -> None:
    with pytest.raises(ValueError, match="'servo' demonstrator"):
        CNNObservation(gym.make("ImitateVideo-v0", scenario="exp2-servo", n_frames=5))
