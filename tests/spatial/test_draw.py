"""The side view: an arm reaching toward the camera is drawn to the inset's right."""

import numpy as np

from imimic_gym.spatial import ArmPose
from imimic_gym.spatial.draw import draw_side_view

# A right arm of a person facing the camera 2 m away, held straight out toward the camera.
REACH = np.array([[-0.2, 0, 2], [-0.2, 0, 1.7], [-0.2, 0, 1.45], [-0.2, 0, 1.35],
                  [0.2, 0, 2], [-0.15, 0.5, 2], [0.15, 0.5, 2]])


def yellow(picture: np.ndarray) -> np.ndarray:
    return (picture[..., 0] > 200) & (picture[..., 1] > 180) & (picture[..., 2] < 80)


def test_an_arm_toward_the_camera_points_right_in_the_side_view() -> None:
    picture = np.zeros((240, 320, 3), np.uint8)
    arm = ArmPose("right", REACH, np.ones(7), np.zeros((7, 2)))
    drawn = draw_side_view(picture, arm, size=80)
    inset = drawn[160:, :80]
    ys, xs = np.nonzero(yellow(inset))
    assert xs.min() >= 34 and xs.max() > 70  # from the shoulder (centre, its dot) rightward
    assert abs(ys.mean() - 40) < 4  # level with the shoulder
    assert not yellow(drawn[:160]).any() and not picture.any()  # a copy, only the inset


def test_a_raised_arm_points_up() -> None:
    points = REACH.copy()
    points[1:4] = [[-0.2, -0.3, 2], [-0.2, -0.55, 2], [-0.2, -0.65, 2]]
    drawn = draw_side_view(np.zeros((240, 320, 3), np.uint8),
                           ArmPose("right", points, np.ones(7), np.zeros((7, 2))), size=80)
    ys, xs = np.nonzero(yellow(drawn[160:, :80]))
    assert ys.min() < 8 and abs(xs.mean() - 40) < 4


def test_in_place_draws_the_same_inset_on_the_picture_itself() -> None:
    arm = ArmPose("right", REACH, np.ones(7), np.zeros((7, 2)))
    copy = draw_side_view(np.full((240, 320, 3), 9, np.uint8), arm, size=80)
    picture = np.full((240, 320, 3), 9, np.uint8)
    assert draw_side_view(picture, arm, size=80, in_place=True) is picture
    np.testing.assert_array_equal(picture, copy)
