import gymnasium as gym
import numpy as np
import pytest

import imimic_gym  # noqa: F401
from imimic_gym.controllers import EstimateTarget, PDController
from imimic_gym.metrics import angle_rmse_deg
from imimic_gym.rollout import run_episode
from imimic_gym.wrappers import CNNObservation, estimate_fields


def still_arm_rmse(env: gym.Env, trajectory) -> float:
    """RMSE of a robot that holds the middle of its joint ranges: the bar to beat."""
    middle = np.mean(np.asarray(env.unwrapped.arm.joint_ranges), axis=1)
    return angle_rmse_deg(np.tile(middle, (len(trajectory.target), 1)), trajectory.target)


def test_cnn_observation_drives_the_robot_after_the_forearm() -> None:
    env = CNNObservation(gym.make("ImitateVideo-v0", scenario="default", clip_seeds=(7,),
                                  n_frames=45), keep_frame=False)
    obs, _ = env.reset(seed=0)
    assert obs["estimate"].shape == (6,) and obs["estimate"].dtype == np.float32
    fields = estimate_fields(1)
    assert np.all(np.isfinite(obs["estimate"])) and obs["estimate"][fields["trust"]] == 1.0
    trajectory = run_episode(env, PDController(env, EstimateTarget(env)), seed=0)
    rmse = trajectory.metrics()["rmse_deg"]
    # measured 4.6 deg against the still arm's 33.3 (0.14 of it) on clip seed 7 (issue 40:
    # about 2x)
    assert rmse < 10.0 and rmse < 0.3 * still_arm_rmse(env, trajectory)


def test_cnn_observation_follows_two_links_better_than_a_still_arm() -> None:
    env = CNNObservation(gym.make("ImitateVideo-v0", scenario="chain-2", clip_seeds=(7,),
                                  n_frames=45), keep_frame=False)
    trajectory = run_episode(env, PDController(env, EstimateTarget(env)), seed=0)
    assert env.observation_space["estimate"].shape == (10,)
    # measured 23.5 deg against the still arm's 29.8 on clip seed 7: 21% better (the ratio
    # 0.35-0.79 on seeds 7-11, the elbow 14-31 deg off: the shipped 2-link CNN is weak);
    # the bound asks for about half that gain (issue 40)
    assert trajectory.metrics()["rmse_deg"] < 0.9 * still_arm_rmse(env, trajectory)


def test_cnn_observation_refuses_the_servo() -> None:
    with pytest.raises(ValueError, match="'servo' demonstrator"):
        CNNObservation(gym.make("ImitateVideo-v0", scenario="exp2-servo", n_frames=5))
