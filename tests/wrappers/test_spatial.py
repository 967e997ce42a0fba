"""RetargetedEstimator: a spatial reading retargeted onto the robot, held where the arm is
not seen; fed here by the clip's own truth, replayed frame by frame."""

import numpy as np
import pytest

from imimic_gym.clips.cache import load_clip
from imimic_gym.clips.scenarios import get_scenario
from imimic_gym.retarget import DirectionRetargeter
from imimic_gym.spatial.truth import arm_poses
from imimic_gym.wrappers.spatial import RetargetedEstimator

UNSEEN = (5, 6, 7)


class Replay:
    """A spatial estimator that reads the truth's poses in order (trust 0 on UNSEEN)."""

    def __init__(self, poses):
        self.poses, self.i = poses, 0

    def reset(self) -> None:
        self.i = 0

    def update(self, frame, depth=None):
        pose = self.poses[self.i]
        self.i += 1
        return pose.held() if self.i - 1 in UNSEEN else pose


@pytest.fixture(scope="module")
def clip():
    return load_clip(get_scenario("spatial-wave", n_frames=20, seed=4), progress=False)


def test_targets_are_the_retargeted_readings_and_held_where_unseen(clip) -> None:
    truth = arm_poses(clip)
    retarget = DirectionRetargeter()
    start = np.zeros(6)
    estimator = RetargetedEstimator(Replay(truth), retarget, fps=clip.fps, start=start)
    estimator.reset()
    previous, expected = None, []
    for i, pose in enumerate(truth):
        if i not in UNSEEN:
            previous = retarget(pose, previous)
        expected.append(previous)
    estimates = [estimator.update(frame) for frame in clip.frames]
    for i, (estimate, want) in enumerate(zip(estimates, expected, strict=True)):
        np.testing.assert_allclose(estimate.angles, want, atol=1e-12)
        if i in UNSEEN:
            assert estimate.trust == 0.0 and estimate.keypoints is None
            assert not estimate.omega.any() and not estimate.alpha.any()
        else:
            assert estimate.trust == 1.0 and estimate.keypoints.shape == (4, 2)
    # After a gap the rates start afresh: no velocity spike from the held frames.
    assert np.abs(np.degrees(estimates[UNSEEN[-1] + 1].omega)).max() < 1.0
    assert "elbow" in estimator.caption()


def test_before_any_reading_the_targets_are_the_start_pose(clip) -> None:
    truth = arm_poses(clip)
    start = np.full(6, 0.1)
    estimator = RetargetedEstimator(Replay([p.held() for p in truth]), DirectionRetargeter(),
                                    fps=clip.fps, start=start)
    estimate = estimator.update(clip.frames[0])
    np.testing.assert_array_equal(estimate.angles, start)
    assert estimate.trust == 0.0 and estimator.caption().endswith("eta 0.00")
