import gymnasium as gym
import numpy as np
import pytest

import imimic_gym  # noqa: F401
from imimic_gym.controllers import (
    SCRIPTED_CONTROLLERS,
    OracleController,
    PDController,
    PositionController,
    TorqueController,
    TruthTarget,
)
from imimic_gym.rollout import run_episode


def test_oracle_tracks_the_servo_within_two_degrees() -> None:
    env = gym.make("ImitateVideo-v0", scenario="exp2-servo", clip_seeds=(100, 101))
    for seed in (0, 1):
        metrics = run_episode(env, OracleController(env), seed=seed).metrics()
        # measured 0.37 and 0.53 deg on reset seeds 0, 1 (issue 40: about 2x)
        assert metrics["rmse_deg"] < 1.1
        assert metrics["lag_frames"] <= 2
        assert metrics["frames"] == 150


@pytest.mark.parametrize("scenario", ["exp2-servo", "chain-2"])
# Measured on clip seed 0 (exp2-servo, chain-2): position 0.71, 0.78 deg; velocity 0.57,
# 0.67; torque 3.8, 4.1 (issue 40: about 2x, torque's bound left at 1.5x).
@pytest.mark.parametrize(("control", "bound_deg"), [("position", 1.6), ("velocity", 1.4),
                                                    ("torque", 6.0)])
def test_pd_tracks_the_truth_in_every_control_mode(scenario: str, control: str,
                                                   bound_deg: float) -> None:
    env = gym.make("ImitateVideo-v0", scenario=scenario, control=control, n_frames=90)
    metrics = run_episode(env, PDController(env, TruthTarget(env)), seed=0).metrics()
    assert metrics["rmse_deg"] < bound_deg


def test_pd_on_a_vertical_two_link_arm_fights_gravity() -> None:
    env = gym.make("ImitateVideo-v0", scenario="chain-2", n_frames=90)
    metrics = run_episode(env, OracleController(env), seed=0).metrics()
    assert metrics["rmse_deg"] < 1.6  # measured 0.78 deg on clip seed 0 (issue 40: about 2x)


def test_doing_nothing_is_much_worse_than_the_oracle() -> None:
    env = gym.make("ImitateVideo-v0", scenario="exp2-servo", n_frames=90)
    still = run_episode(env, lambda obs: np.zeros(1, dtype=np.float32), seed=0).metrics()
    oracle = run_episode(env, OracleController(env), seed=0).metrics()
    # measured 26.0 against 0.71 deg (37 times) on clip seed 0 (issue 40: about half)
    assert still["rmse_deg"] > 18 * oracle["rmse_deg"]


def truth_env(control: str, **kwargs) -> gym.Env:
    from imimic_gym.wrappers import TruthObservation

    return TruthObservation(gym.make("ImitateVideo-v0", scenario="exp2-servo", control=control,
                                     n_frames=90, **kwargs), keep_frame=False)


# Measured on clip seed 0: position 0.74 deg, velocity 0.33, torque 0.077 (issue 40:
# about 2x).
@pytest.mark.parametrize(("control", "bound_deg"), [("position", 1.5), ("velocity", 0.6),
                                                    ("torque", 0.16)])
def test_each_scripted_controller_tracks_a_known_target(control: str, bound_deg: float) -> None:
    # The estimate is the clip's exact angle, omega and alpha: what is left is the
    # controller's own error. The feed-forward controllers need no lead to keep up.
    env = truth_env(control)
    metrics = run_episode(env, SCRIPTED_CONTROLLERS[control](env), seed=0).metrics()
    assert metrics["rmse_deg"] < bound_deg
    assert abs(metrics["lag_frames"]) <= 1


def test_the_servo_waits_for_dons_first_reading() -> None:
    # Clip 100: DON's placeholder (the middle of the range, trust 0) is 34 degrees off
    # for four frames. Chasing it drives the robot away and back (RMSE above 2.5 deg);
    # waiting for DON's first reading keeps the robot on the arm.
    from imimic_gym.wrappers import DONObservation, estimate_fields

    env = DONObservation(gym.make("ImitateVideo-v0", scenario="exp2-servo",
                                  clip_seeds=(100,)), keep_frame=False)
    obs, _ = env.reset(seed=0)
    assert obs["estimate"][estimate_fields(1)["trust"]][0] == 0.0
    rollout = run_episode(env, PositionController(env), seed=0)
    assert rollout.metrics()["rmse_deg"] < 2.5  # measured 1.6 deg
    # measured 0.57 deg (issue 40: about 2x)
    assert np.degrees(abs(rollout.robot[3, 0] - rollout.target[3, 0])) < 1.2
    assert 0.0 < rollout.metrics()["mean_trust"] <= 1.0


def test_computed_torque_uses_the_estimated_acceleration() -> None:
    env = truth_env("torque")
    with_alpha = run_episode(env, TorqueController(env), seed=0).metrics()
    without = run_episode(env, TorqueController(env, alpha_feedforward=0.0), seed=0).metrics()
    # measured 0.077 against 0.46 deg (0.17 of it) on clip seed 0 (issue 40: about 2x)
    assert with_alpha["rmse_deg"] < 0.35 * without["rmse_deg"]


@pytest.mark.parametrize("name", ["position", "velocity", "torque"])
def test_a_controller_refuses_the_wrong_actuation(name: str) -> None:
    other = "torque" if name != "torque" else "position"
    env = truth_env(other)
    with pytest.raises(ValueError, match=f"drives control='{name}' actuation; this env has "
                                         f"control='{other}'"):
        SCRIPTED_CONTROLLERS[name](env)
