"""The baselines run behind DON's interface, on the same geometry, with defined output."""

import math

import cv2
import numpy as np
import pytest

from imimic_gym.estimators.baselines import CamShiftEstimator, MOG2Estimator
from imimic_gym.estimators.types import Estimate
from tests.estimators.don.test_one_link import FPS, PIVOT, H, W, sweep


def coloured_bar(angle: float) -> np.ndarray:
    """An orange bar on a grey background (CamShift needs a hue to follow)."""
    frame = np.full((H, W, 3), 90, dtype=np.uint8)
    tip = PIVOT + 100 * np.array([math.cos(angle), -math.sin(angle)])
    cv2.line(frame, tuple(PIVOT.astype(int)), tuple(np.rint(tip).astype(int)),
             (240, 130, 20), thickness=10)
    return frame


@pytest.mark.parametrize("estimator", [MOG2Estimator, CamShiftEstimator])
def test_baseline_follows_a_turning_bar(estimator) -> None:
    angles = sweep(3.0, 90)
    estimates = estimator(fps=FPS, joint_range=(0.0, math.pi)).run(
        coloured_bar(a) for a in angles)
    assert all(isinstance(e, Estimate) for e in estimates)
    late = [abs(math.degrees(e.angles[0] - a)) for e, a in zip(estimates, angles, strict=True)][45:]
    assert np.median(late) < 0.6  # measured 0.28 deg MOG2, 0.22 CamShift (issue 40: about 2x)


@pytest.mark.parametrize("estimator", [MOG2Estimator, CamShiftEstimator])
def test_baseline_output_is_defined_on_still_and_black_input(estimator) -> None:
    black = np.zeros((H, W, 3), dtype=np.uint8)
    for estimate in estimator(fps=FPS).run([black] * 12):
        # Nothing read: a placeholder with trust 0.
        assert np.all(np.isfinite(estimate.as_vector())) and estimate.trust == 0.0


@pytest.mark.parametrize("estimator", [MOG2Estimator, CamShiftEstimator])
def test_a_copied_or_pickled_baseline_runs_like_a_new_one(estimator) -> None:
    """gymnasium deep-copies a wrapper's arguments, vector envs pickle them."""
    import copy
    import pickle

    angles = sweep(3.0, 60)
    frames = [coloured_bar(a) for a in angles]
    original = estimator(fps=FPS, joint_range=(0.0, math.pi))
    expected = [e.angles[0] for e in original.run(frames)]
    for clone in (copy.deepcopy(original), pickle.loads(pickle.dumps(original))):
        assert [e.angles[0] for e in clone.run(frames)] == expected
