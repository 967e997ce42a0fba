"""Property-based checks (hypothesis): random shapes, dtypes, frame rates, NaNs and
extreme numbers thrown at the estimators, the env's constructor and its step. Each gives
a specific error or finite output, never a crash elsewhere or a NaN."""

import math

import gymnasium as gym
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

import imimic_gym  # noqa: F401
from imimic_gym.clips.types import Clip
from imimic_gym.estimators.registry import build_estimator
from imimic_gym.estimators.types import EstimatorContext

SETTINGS = settings(max_examples=25, deadline=None,
                    suppress_health_check=[HealthCheck.too_slow])
ONE_LINK = EstimatorContext(fps=30.0, link_parents=(-1,), joint_ranges=((-1.0, 1.0),),
                            reference_direction=-math.pi / 2)
VIDEO_ESTIMATORS = ("don", "don-paper", "mog2", "camshift", "cnn")


def finite(estimate) -> bool:
    return all(np.isfinite(getattr(estimate, name)).all()
               for name in ("angles", "omega", "alpha", "torque")) and 0 <= estimate.trust <= 1


@pytest.mark.parametrize("name", VIDEO_ESTIMATORS)
@SETTINGS
@given(frames=st.lists(hnp.arrays(np.uint8, st.tuples(st.integers(1, 48), st.integers(1, 48),
                                                       st.just(3)),
                                  elements=st.sampled_from([0, 1, 127, 254, 255])),
                       min_size=1, max_size=4),
       repeats=st.integers(1, 6))
def test_any_rgb_frames_give_finite_estimates(name, frames, repeats) -> None:
    estimator = build_estimator(name, ONE_LINK)
    estimator.reset()
    shape = frames[0].shape
    for frame in [f if f.shape == shape else frames[0] for f in frames] * repeats:
        assert finite(estimator.update(frame))


@pytest.mark.parametrize("name", VIDEO_ESTIMATORS)
@SETTINGS
@given(frame=st.one_of(
    hnp.arrays(st.sampled_from([np.float32, np.float64, np.uint16, np.int8, np.bool_]),
               st.tuples(st.integers(1, 16), st.integers(1, 16), st.just(3))),
    hnp.arrays(np.uint8, st.tuples(st.integers(0, 16), st.integers(0, 16),
                                   st.sampled_from([1, 2, 4]))),
    hnp.arrays(np.uint8, st.tuples(st.integers(0, 16), st.integers(0, 16)))))
def test_frames_that_are_not_rgb_uint8_are_a_value_error(name, frame) -> None:
    estimator = build_estimator(name, ONE_LINK)
    estimator.reset()
    with pytest.raises(ValueError, match=r"\(H, W, 3\) uint8"):
        estimator.update(frame)


@SETTINGS
@given(fps=st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.integers(-5, 5)))
def test_any_frame_rate_is_taken_or_named(fps) -> None:
    from imimic_gym.estimators.baselines import CamShiftEstimator, MOG2Estimator
    from imimic_gym.estimators.don.one_link import DON

    valid = math.isfinite(fps) and fps > 0
    for make in (DON, MOG2Estimator, CamShiftEstimator):
        if not valid:
            with pytest.raises(ValueError, match="fps must be a positive, finite number"):
                make(fps=fps)
            continue
        estimator = make(fps=fps)
        frame = np.zeros((24, 32, 3), np.uint8)
        for picture in (frame, frame + 200, frame, frame + 200):
            assert finite(estimator.update(picture))
    if not valid:
        with pytest.raises(ValueError, match="fps must be a positive number"):
            EstimatorContext(fps=fps, link_parents=(-1,), joint_ranges=((0.0, 1.0),),
                             reference_direction=0.0)


def tiny_clip(frames: int = 3) -> Clip:
    rng = np.random.default_rng(frames)
    return Clip(frames=rng.integers(0, 255, (frames, 16, 24, 3), dtype=np.uint8), fps=30.0)


@SETTINGS
@given(kwargs=st.fixed_dictionaries({}, optional={
    "tracking_weight": st.floats(allow_nan=True, allow_infinity=True),
    "ctrl_cost_weight": st.floats(allow_nan=True, allow_infinity=True),
    "reset_noise_scale": st.floats(-1, 1),
    "render_height": st.one_of(st.integers(-3, 5000), st.booleans()),
    "control": st.sampled_from(["position", "velocity", "torque", "thrust"]),
}))
def test_the_constructor_takes_or_names_every_argument(kwargs) -> None:
    try:
        env = gym.make("ImitateVideo-v0", scenario=tiny_clip(), **kwargs)
    except ValueError as error:
        assert any(key in str(error) for key in kwargs)
        return
    obs, _ = env.reset(seed=0)
    obs, reward, *_ = env.step(env.action_space.sample())
    assert np.isfinite(reward) and np.isfinite(obs["qpos"]).all()
    env.close()


@SETTINGS
@given(action=st.one_of(
    hnp.arrays(np.float64, st.integers(0, 3), elements=st.floats(allow_nan=True,
                                                                  allow_infinity=True)),
    hnp.arrays(np.float32, 1, elements=st.floats(width=32, allow_nan=False))))
def test_any_action_steps_finitely_or_is_named(action) -> None:
    env = gym.make("ImitateVideo-v0", scenario=tiny_clip(), control="torque")
    env.reset(seed=0)
    try:
        obs, reward, *_ = env.step(action)
    except ValueError as error:
        assert "action must" in str(error)
        assert action.shape != (1,) or not np.isfinite(action).all()
    else:
        assert action.shape == (1,) and np.isfinite(action).all()
        assert np.isfinite(reward) and np.isfinite(obs["qpos"]).all()
    env.close()
