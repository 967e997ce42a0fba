"""`wrap_angle`: the short way round, and a float's arithmetic the array's to the bit."""

import numpy as np
import pytest

from imimic_gym.kinematics import wrap_angle


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
