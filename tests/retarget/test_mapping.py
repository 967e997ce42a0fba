"""PersonToRobot: the mirror mapping and its checks."""

import numpy as np
import pytest

from imimic_gym.retarget import MAPPINGS, MIRROR, PersonToRobot


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
