"""RenderAhead: the robot view drawn while the estimator works, the same pictures."""

import gymnasium as gym
import mujoco
import numpy as np

from imimic_gym.render import OffscreenRenderer
from imimic_gym.wrappers import RenderAhead


def make(**kwargs) -> gym.Env:
    return gym.make("ImitateVideo-v0", scenario="default", n_frames=8, **kwargs)


def test_the_pictures_are_a_plain_renders() -> None:
    plain, ahead = make(render_mode="rgb_array"), RenderAhead(make(render_mode="rgb_array"))
    plain.reset(seed=3)
    ahead.reset(seed=3)
    actions = np.linspace(-1.0, 1.0, 7, dtype=np.float32)
    try:
        for action in [None, *actions]:
            if action is not None:
                plain.step(np.array([action]))
                ahead.step(np.array([action]))
                # The view of this state was started by the step, before render.
                assert ahead.unwrapped._robot_view_started is not None
            np.testing.assert_array_equal(ahead.render(), plain.render())
    finally:
        plain.close()
        ahead.close()


def test_a_robot_moved_after_the_step_is_drawn_where_it_is() -> None:
    env = RenderAhead(make(render_mode="rgb_array"))
    env.reset(seed=0)
    env.step(np.array([0.5], dtype=np.float32))
    started = env.render()
    env.step(np.array([0.5], dtype=np.float32))  # the view of this state is started ...
    inner = env.unwrapped
    inner.data.qpos[:] = inner.data.qpos + 0.8  # ... and the arm then moved by hand
    mujoco.mj_forward(inner.model, inner.data)
    picture = env.render()
    with OffscreenRenderer(inner.model, 240, 320) as renderer:
        robot, _ = renderer.render(inner.data, inner.model.camera("robot").id)
    np.testing.assert_array_equal(picture[:, 320:], robot)
    assert np.abs(picture[:, 320:].astype(int) - started[:, 320:]).max() > 50  # it moved
    env.close()


def test_without_render_mode_nothing_is_drawn() -> None:
    env = RenderAhead(make())
    env.reset(seed=0)
    env.step(np.array([0.1], dtype=np.float32))
    assert env.unwrapped._renderer is None
    env.close()
