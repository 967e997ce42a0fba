"""PersonToRobot: the mirror and tilted mappings and their checks."""

import math

import numpy as np
import pytest

from imimic_gym.retarget import MAPPINGS, MIRROR, TILTED, PersonToRobot


def test_mirror_keeps_forward_outward_up_as_the_robots_forward_left_up():
    np.testing.assert_allclose(MIRROR.to_robot([0.2, 0.3, 0.9]), [0.2, 0.3, 0.9])
    assert MAPPINGS["mirror"] is MIRROR


def test_to_arm_inverts_to_robot():
    turned = PersonToRobot("turned", ((0.0, -1.0, 0.0), (1.0, 0.0, 0.0), (0.0, 0.0, 1.0)),
                           "a quarter turn")
    v = np.array([0.1, -0.4, 0.7])
    np.testing.assert_allclose(turned.to_arm(turned.to_robot(v)), v, atol=1e-12)


def test_a_mapping_must_be_a_rotation():
    with pytest.raises(ValueError, match="'flip': robot_from_arm must be a"):
        PersonToRobot("flip", ((-1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)), "")


def test_tilted_turns_the_arm_frame_forward_up_about_the_outward_axis():
    assert MAPPINGS["tilted"] is TILTED
    np.testing.assert_allclose(TILTED.to_robot([0.0, 1.0, 0.0]), [0.0, 1.0, 0.0], atol=1e-12)
    # A hanging arm points 24 degrees below the robot's horizon, forward: as low as the
    # robot's upper arm goes (tests/retarget/test_directions.py: 76 - 100 degrees).
    hanging = TILTED.to_robot([0.0, 0.0, -1.0])
    assert math.degrees(math.atan2(hanging[2], hanging[0])) == pytest.approx(-24.0)
    assert hanging[1] == pytest.approx(0.0)
    # Reaching forward points 66 degrees up.
    forward = TILTED.to_robot([1.0, 0.0, 0.0])
    assert math.degrees(math.atan2(forward[2], forward[0])) == pytest.approx(66.0)


def test_a_mapping_is_its_rotation_applied_to_rows_of_directions():
    turned = PersonToRobot("turned", ((0.0, -1.0, 0.0), (1.0, 0.0, 0.0), (0.0, 0.0, 1.0)),
                           "a quarter turn")
    assert turned.matrix.dtype == np.float64 and turned.matrix.shape == (3, 3)
    np.testing.assert_array_equal(turned.matrix, turned.robot_from_arm)
    arm = np.array([[1.0, 0.0, 0.0], [0.0, 2.0, 0.5]])
    np.testing.assert_array_equal(turned.to_robot(arm), [[0.0, 1.0, 0.0], [-2.0, 0.0, 0.5]])
    np.testing.assert_array_equal(turned.to_arm([[0.0, 1.0, 0.0], [-2.0, 0.0, 0.5]]), arm)
    np.testing.assert_array_equal(turned.to_robot([1, 0, 0]), [0.0, 1.0, 0.0])
    assert turned.to_robot([1, 0, 0]).dtype == turned.to_arm([1, 0, 0]).dtype == np.float64


@pytest.mark.parametrize("rows", [
    ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0)),                                  # not 3 x 3
    ((2.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)),                 # stretches
    ((1.0, 0.0, 0.0), (0.0, 1.0, 1e-6), (0.0, 0.0, 1.0)),                # shears a little
    ((0.0, 1.0, 0.0), (1.0, 0.0, 0.0), (0.0, 0.0, 1.0)),                 # a reflection
])
def test_only_a_rotation_is_a_mapping(rows):
    with pytest.raises(ValueError, match=r"^PersonToRobot 'bad': robot_from_arm must be a "
                                         r"\(3, 3\) rotation, got \("):
        PersonToRobot("bad", rows, "")


def test_a_rotation_rounded_within_1e_9_is_a_mapping():
    c, s = math.cos(0.3), math.sin(0.3)
    for rounding in (1e-10, -1e-10):  # its determinant a hair above 1, then below
        rounded = ((c + rounding, -s, 0.0), (s, c, 0.0), (0.0, 0.0, 1.0))
        assert PersonToRobot("rounded", rounded, "").name == "rounded"
    sheared = ((1.0, 0.0, 0.0), (5e-9, 1.0, 0.0), (0.0, 0.0, 1.0))  # rows 5e-9 off square
    with pytest.raises(ValueError, match="'sheared': robot_from_arm must be a"):
        PersonToRobot("sheared", sheared, "")


def test_the_mappings_are_named_and_described_for_help():
    np.testing.assert_array_equal(MIRROR.matrix, np.eye(3))
    tilt = math.radians(66.0)
    np.testing.assert_allclose(TILTED.matrix, [[math.cos(tilt), 0, -math.sin(tilt)], [0, 1, 0],
                                               [math.sin(tilt), 0, math.cos(tilt)]],
                               atol=1e-15)
    assert list(MAPPINGS) == ["mirror", "tilted"]
    assert MIRROR.description == (
        "the robot faces the person like their mirror image: the person's forward, outward "
        "and up are the robot's forward, left and up")
    assert TILTED.description == (
        "as mirror, turned 66 degrees forward-up about the outward axis: a hanging arm "
        "points forward-down, an arm reaching forward points up, so a relaxed arm stays in "
        "reach")
