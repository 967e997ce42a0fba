"""The path estimator's correction of its newest location."""

import numpy as np
import pytest

from imimic_gym.estimators.motion import PathEstimator


def test_a_corrected_location_recomputes_its_velocity_and_acceleration() -> None:
    path = PathEstimator(1, fps=10.0)
    for location in (0.0, 0.1, 0.25):
        path.update(np.array([location]))
    v, a = path.correct(np.array([0.3]))
    assert v[0] == pytest.approx(0.2) and a[0] == pytest.approx(0.1)
    assert list(path.V)[-1][0] == pytest.approx(0.2) and len(path.V) == 3
    assert path.location[0] == pytest.approx(0.3)
    assert path.omega()[0] == pytest.approx((0.2 + 0.1) / 2 * 10.0)


def test_correcting_the_first_location_after_a_reset_gives_no_velocity() -> None:
    path = PathEstimator(1, fps=10.0)
    path.update(np.array([1.0]))
    path.reset()
    path.update(np.array([2.0]))
    v, a = path.correct(np.array([2.5]))
    assert v[0] == 0.0 and a[0] == 0.0 and path.location[0] == 2.5


def test_a_location_of_the_wrong_length_is_refused() -> None:
    path = PathEstimator(2, fps=10.0)
    with pytest.raises(ValueError, match="tracks 2 angles, got 1"):
        path.update(np.array([0.1]))
