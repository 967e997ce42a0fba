"""`Estimate` refuses what a controller could not use: non-finite values, mismatched
shapes, a trust factor outside [0, 1]."""

import numpy as np
import pytest

from imimic_gym.estimators.types import Estimate


def estimate(**fields: object) -> Estimate:
    values = {"angles": [0.1, -0.2], "omega": [1.0, 0.0], "alpha": [0.0, 2.0],
              "torque": [0.5, 0.25], "trust": 0.75, **fields}
    return Estimate(**values)


def test_estimate_stores_float64_arrays_and_packs_a_vector() -> None:
    est = estimate(predicted=True)
    assert est.angles.dtype == np.float64 and est.torque.shape == (2,)
    assert est.as_vector().tolist() == pytest.approx(
        [0.1, -0.2, 1.0, 0.0, 0.0, 2.0, 0.5, 0.25, 0.75, 1.0])


@pytest.mark.parametrize("name", ["angles", "omega", "alpha", "torque"])
@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_a_non_finite_field_is_refused_by_name(name: str, bad: float) -> None:
    with pytest.raises(ValueError, match=rf"Estimate\.{name} must be finite"):
        estimate(**{name: [0.0, bad]})


def test_a_field_of_another_shape_or_a_trust_outside_0_1_is_refused() -> None:
    with pytest.raises(ValueError, match=r"Estimate\.omega must be finite with shape"):
        estimate(omega=[1.0])
    with pytest.raises(ValueError, match=r"Estimate\.trust must be in \[0, 1\], got 1.5"):
        estimate(trust=1.5)
