"""`spatial.camera.Intrinsics`: cameras from a field of view, and the guessed one."""

import math

import numpy as np
import pytest

from imimic_gym.spatial.camera import GUESSED_FOV_DEG, Intrinsics


@pytest.mark.parametrize(("width", "height"), [(1280, 720), (720, 1280), (640, 640)])
@pytest.mark.parametrize("fov", [10.0, 60.0, 84.1, 170.0])
def test_a_camera_from_its_field_of_view_spans_it_across_the_longer_side(
        width, height, fov) -> None:
    camera = Intrinsics.from_fov(fov, width, height)
    assert camera.fov_deg == pytest.approx(fov, abs=1e-9)
    assert (camera.fx, camera.cx, camera.cy) == (camera.fy, width / 2, height / 2)
    # The rays through the middles of the longer side's two edges are fov apart.
    edges = ([[0, height / 2], [width, height / 2]] if width >= height
             else [[width / 2, 0], [width / 2, height]])
    rays = camera.rays(np.array(edges, float))
    cosine = rays[0] @ rays[1] / np.linalg.norm(rays[0]) / np.linalg.norm(rays[1])
    assert math.degrees(math.acos(cosine)) == pytest.approx(fov, abs=1e-9)


def test_footage_of_an_unknown_camera_is_read_through_the_guessed_field_of_view() -> None:
    assert Intrinsics.guess(1920, 1080) == Intrinsics.from_fov(GUESSED_FOV_DEG, 1920, 1080)
    assert Intrinsics.guess(1080, 1920).fov_deg == pytest.approx(GUESSED_FOV_DEG)


@pytest.mark.parametrize("fov", [0.0, 180.0, -5.0, math.nan, math.inf])
def test_a_field_of_view_outside_0_to_180_degrees_is_refused(fov) -> None:
    with pytest.raises(ValueError, match="field of view must be in"):
        Intrinsics.from_fov(fov, 640, 480)
