"""ArmPose: the arm frame, directions and flexion on hand-made arms, and the mirror rule."""

import math

import numpy as np
import pytest

from imimic_gym.spatial import ArmPose, Intrinsics

# A right arm of a person facing the camera 2 m away: upper arm hanging, forearm toward
# the camera (a 90-degree elbow).
RIGHT = np.array([[-0.2, 0, 2], [-0.2, 0.3, 2], [-0.2, 0.3, 1.75], [-0.2, 0.3, 1.65],
                  [0.2, 0, 2], [-0.15, 0.5, 2], [0.15, 0.5, 2]])


def pose(side: str, points: np.ndarray) -> ArmPose:
    return ArmPose(side, points, np.ones(7), np.zeros((7, 2)))


def test_arm_frame_directions_and_flexion():
    arm = pose("right", RIGHT)
    np.testing.assert_allclose(arm.arm_frame(), [[0, 0, -1], [-1, 0, 0], [0, -1, 0]],
                               atol=1e-12)
    np.testing.assert_allclose(arm.in_arm_frame(arm.upper_arm), [0, 0, -1], atol=1e-12)
    np.testing.assert_allclose(arm.in_arm_frame(arm.forearm), [1, 0, 0], atol=1e-12)
    assert arm.elbow_flexion == pytest.approx(math.pi / 2)
    np.testing.assert_allclose(arm.bone_lengths, [0.3, 0.25, 0.1])


def test_a_left_arm_is_the_mirrored_right_arm():
    mirrored = RIGHT * np.array([-1, 1, 1])
    right, left = pose("right", RIGHT), pose("left", mirrored)
    for direction in ("upper_arm", "forearm", "hand"):
        np.testing.assert_allclose(left.in_arm_frame(getattr(left, direction)),
                                   right.in_arm_frame(getattr(right, direction)), atol=1e-12)


def test_a_raised_sideways_arm_points_outward_and_up():
    points = RIGHT.copy()
    points[1] = points[0] + [-0.3 * math.cos(math.radians(30)), -0.3 * 0.5, 0]
    arm = pose("right", points)
    np.testing.assert_allclose(arm.in_arm_frame(arm.upper_arm),
                               [0, math.cos(math.radians(30)), 0.5], atol=1e-12)


def test_without_hips_up_is_the_cameras():
    points = RIGHT.copy()
    points[5:] = [[0, 5, 9], [1, 5, 9]]  # junk hips, unseen
    arm = ArmPose("right", points, np.array([1, 1, 1, 1, 1, 0.1, 0.1]), np.zeros((7, 2)))
    np.testing.assert_allclose(arm.arm_frame()[2], [0, -1, 0], atol=1e-12)


@pytest.mark.parametrize("bad", [np.nan, np.inf])
def test_non_finite_points_are_refused(bad):
    points = RIGHT.copy()
    points[2, 1] = bad
    with pytest.raises(ValueError, match=r"ArmPose\.points must be finite"):
        pose("right", points)


def test_intrinsics_round_trip():
    camera = Intrinsics.from_fovy(45, 320, 240)
    pixels = camera.project(RIGHT)
    np.testing.assert_allclose(camera.back_project(pixels, RIGHT[:, 2]), RIGHT, atol=1e-12)
    assert camera.project(np.array([0, 0, 3.0])) == pytest.approx([160, 120])
