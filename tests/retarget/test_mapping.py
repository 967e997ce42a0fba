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
