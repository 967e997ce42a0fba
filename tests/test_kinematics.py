"""`wrap_angle`: the short way round, and a float's arithmetic the array's to the bit;
`keypoints_to_angles` on hand-made arms."""

import numpy as np
import pytest

from imimic_gym.kinematics import keypoints_to_angles, wrap_angle


def test_wrap_angle_takes_the_short_way_round() -> None:
    assert np.degrees(wrap_angle(np.radians(359.0))) == pytest.approx(-1.0)
    assert np.degrees(wrap_angle(np.radians(-181.0))) == pytest.approx(179.0)


def test_wrap_angle_of_a_float_is_the_arrays_float_to_the_bit() -> None:
    angles = np.concatenate([np.random.default_rng(0).normal(scale=20.0, size=2000),
                             np.arange(-8, 9) * np.pi, [0.0, -0.0, 1e-300]])
    wrapped = [wrap_angle(angle) for angle in angles.tolist()]
    assert all(type(w) is float for w in wrapped)
    assert np.array_equal(wrapped, wrap_angle(angles))
    assert wrap_angle(np.pi) == -np.pi and wrap_angle(-np.pi) == -np.pi


# Shoulder, elbow, wrist pixels (x right, y down): the upper arm hangs straight down the
# image, the forearm points right, so the elbow bends a quarter turn counter-clockwise.
HANGING_ELBOW_RIGHT = np.array([[100.0, 50.0], [100.0, 80.0], [125.0, 80.0]])


def test_one_link_is_the_forearm_from_the_upper_arm_counter_clockwise() -> None:
    angles = keypoints_to_angles(HANGING_ELBOW_RIGHT, 1)
    assert angles.shape == (1,) and angles.dtype == np.float64
    assert angles[0] == pytest.approx(np.pi / 2, abs=1e-12)
    mirrored = HANGING_ELBOW_RIGHT * [-1, 1]  # the forearm points left: clockwise
    assert keypoints_to_angles(mirrored, 1)[0] == pytest.approx(-np.pi / 2, abs=1e-12)


def test_two_links_measure_the_upper_arm_from_the_reference_direction() -> None:
    # The default reference is the image's down (-pi/2): a hanging upper arm is 0.
    np.testing.assert_allclose(keypoints_to_angles(HANGING_ELBOW_RIGHT, 2), [0, np.pi / 2],
                               atol=1e-12)
    np.testing.assert_allclose(keypoints_to_angles(HANGING_ELBOW_RIGHT, 2, 0.0),
                               [-np.pi / 2, np.pi / 2], atol=1e-12)
    np.testing.assert_allclose(keypoints_to_angles(HANGING_ELBOW_RIGHT, 2, np.pi / 4),
                               [-3 * np.pi / 4, np.pi / 2], atol=1e-12)


def test_joint_angles_are_wrapped_the_short_way_round() -> None:
    # Upper arm 0.1 rad above image left, forearm 0.1 rad below it: the elbow bends 0.2
    # rad counter-clockwise (not 0.2 - 2 pi); the upper arm from down is -pi/2 - 0.1
    # wrapped, not 3 pi/2 - 0.1.
    up_left = np.array([-np.cos(0.1), -np.sin(0.1)])
    down_left = np.array([-np.cos(0.1), np.sin(0.1)])
    keypoints = np.array([[0.0, 0.0], 20 * up_left, 20 * up_left + 20 * down_left])
    np.testing.assert_allclose(keypoints_to_angles(keypoints, 2),
                               [-np.pi / 2 - 0.1, 0.2], atol=1e-12)


def test_keypoints_in_a_batch_give_angles_in_the_same_batch() -> None:
    batch = np.stack([HANGING_ELBOW_RIGHT, HANGING_ELBOW_RIGHT * [-1, 1]] * 3).reshape(
        3, 2, 3, 2)
    angles = keypoints_to_angles(batch, 2)
    assert angles.shape == (3, 2, 2)
    np.testing.assert_allclose(angles[:, 0], [[0, np.pi / 2]] * 3, atol=1e-12)
    np.testing.assert_allclose(angles[:, 1], [[0, -np.pi / 2]] * 3, atol=1e-12)


def test_float32_and_integer_pixels_give_the_float64_angles() -> None:
    keypoints = np.array([[3.0, 7.0], [11.0, 40.0], [38.0, 59.0]])
    exact = keypoints_to_angles(keypoints, 2)
    assert keypoints_to_angles(keypoints.astype(np.float32), 2).tolist() == exact.tolist()
    assert keypoints_to_angles(keypoints.astype(np.int64).tolist(), 2).tolist() == \
        exact.tolist()


def test_keypoints_of_the_wrong_shape_or_a_third_link_are_refused() -> None:
    with pytest.raises(ValueError, match=r"shape \(\.\.\., 3, 2\), got \(3, 3\)"):
        keypoints_to_angles(np.zeros((3, 3)), 1)
    with pytest.raises(ValueError, match=r"shape \(\.\.\., 3, 2\), got \(2, 2\)"):
        keypoints_to_angles(np.zeros((2, 2)), 1)
    with pytest.raises(ValueError, match="1 or 2 joint angles, not 3"):
        keypoints_to_angles(HANGING_ELBOW_RIGHT, 3)
