"""The offscreen renderer's pictures, written into a new array or into one given."""

import mujoco
import numpy as np
import pytest

from imimic_gym.render import OffscreenRenderer
from imimic_gym.robots.so101 import SO101Spec


def test_a_picture_drawn_into_a_view_is_the_picture_drawn_alone() -> None:
    model = SO101Spec().build_model()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    camera = model.camera("robot").id
    with OffscreenRenderer(model, 60, 80) as renderer:
        alone, _ = renderer.render(data, camera)
        canvas = np.zeros((60, 200, 3), np.uint8)
        drawn, _ = renderer.render(data, camera, out=canvas[:, 100:180])
        with pytest.raises(ValueError, match=r"out must be \(60, 80, 3\) uint8 for this "
                                             r"renderer, got \(60, 100, 3\) uint8"):
            renderer.render(data, camera, out=canvas[:, :100])
    assert alone.std() > 5  # the robot, not a blank picture
    np.testing.assert_array_equal(canvas[:, 100:180], alone)
    assert drawn.base is canvas  # written into the view, not a copy of it
    assert not canvas[:, :100].any() and not canvas[:, 180:].any()  # nothing else touched


def test_a_picture_started_and_finished_later_is_the_picture_rendered_at_once() -> None:
    model = SO101Spec().build_model()
    data = mujoco.MjData(model)
    data.qpos[:] = [0.3, -0.5, 0.8, 0.2, 1.0, 0.4]
    mujoco.mj_forward(model, data)
    camera = model.camera("robot").id
    with OffscreenRenderer(model, 60, 80) as renderer:
        at_once, _ = renderer.render(data, camera)
        renderer.start(data, camera)
        later = renderer.finish()
        into = np.zeros((60, 80, 3), np.uint8)
        renderer.start(data, camera)
        assert renderer.finish(out=into) is into
    np.testing.assert_array_equal(later, at_once)
    np.testing.assert_array_equal(into, at_once)

