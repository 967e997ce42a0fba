"""The share filter's parts on hand-made beliefs: the spread between frames and the
elbow's flexion from two bones' beliefs (its use in the lift: tests/spatial/test_lift.py)."""

import math

import numpy as np
import pytest

from imimic_gym.spatial import angle_between
from imimic_gym.spatial.lift import lift_arm
from imimic_gym.spatial.share_filter import (
    SHARE_FILTER,
    SHARE_GRID,
    ShareFilter,
    expected_flexion,
    predict_belief,
    uniform_belief,
)
from tests.spatial.test_lift import CAMERA, LENGTHS, arm, observe, random_unit


def test_the_share_filters_belief_spreads_by_its_turn_rate() -> None:
    """A certain share spreads over a frame at 30 fps by a standard deviation of
    turn_rate / 30 (8 / 30 = 0.267; the jump share adds 0.01 of a uniform), and the
    belief stays a distribution; a uniform belief stays uniform."""
    spike = np.zeros(SHARE_GRID.size)
    spike[SHARE_GRID.size // 2] = 1.0
    belief = predict_belief(spike, SHARE_FILTER, 1 / 30)
    assert belief.sum() == pytest.approx(1.0)
    assert (belief >= 0).all()
    spread = math.sqrt(belief @ SHARE_GRID**2 - (belief @ SHARE_GRID) ** 2)
    assert spread == pytest.approx(0.2685, abs=0.002)
    np.testing.assert_allclose(predict_belief(uniform_belief(), ShareFilter(turn_rate=0.0),
                                              1 / 30), uniform_belief(), rtol=1e-9)


def test_the_expected_flexion_of_certain_bones_is_their_angle() -> None:
    """Beliefs all on one share each: the flexion is the angle between the bones those
    shares put in place (the lift's own geometry), for random arms."""
    rng = np.random.default_rng(5)
    for _ in range(20):
        truth = arm("left", random_unit(rng), random_unit(rng))
        pixels, depth = observe(truth)
        pose = lift_arm("left", pixels, np.ones(7), depth, CAMERA, LENGTHS,
                        depth_of_shoulder=truth[0, 2])
        rays = CAMERA.rays(pixels)
        beliefs = []
        for start, end, length in ((0, 1, LENGTHS.upper_arm), (1, 2, LENGTHS.forearm)):
            a = float(rays[end] @ rays[end])
            middle = float(rays[end] @ pose.points[start]) / a
            share = (pose.points[end, 2] / rays[end, 2] - middle) * math.sqrt(a) / length
            belief = np.zeros(SHARE_GRID.size)
            belief[np.argmin(np.abs(SHARE_GRID - share))] = 1.0
            beliefs.append(belief)
        flexion = expected_flexion(pose.points[0], rays[1], rays[2],
                                   (LENGTHS.upper_arm, LENGTHS.forearm),
                                   (beliefs[0], beliefs[1]), ShareFilter(flexion_over_tilts=0.0))
        assert math.degrees(flexion) == pytest.approx(math.degrees(pose.elbow_flexion), abs=3.0)


def test_the_flexion_over_an_unsure_forearms_tilts_is_either_tilts() -> None:
    """An upper arm sure of its share (0) and a forearm split between its two tilts (0.45
    at -0.7, 0.45 at +0.7, 0.1 at 0; expected |share| 0.63, over the 0.6 gate), far off
    the camera's axis (rays longer than 1, where perspective bends the two tilts
    differently: 38 and 28 degrees here): the flexion is the mean of the two tilts' bends,
    solved here from the geometry, to 0.01 degrees (the share at 0 in neither tilt); with
    the gate over 1 it is the bones' angle at the forearm's output share (0), over 5
    degrees straighter."""
    shoulder = np.array([1.2, -0.9, 2.5])  # well off the optical axis: rays longer than 1
    elbow = shoulder + np.array([0.0, LENGTHS.upper_arm, 0.0])
    elbow_ray, wrist_ray = elbow / elbow[2], np.array([0.55, -0.1, 1.0])

    def end(start: np.ndarray, ray: np.ndarray, length: float, share: float) -> np.ndarray:
        a = float(ray @ ray)
        return (float(ray @ start) / a + share * length / math.sqrt(a)) * ray

    upper = np.zeros(SHARE_GRID.size)
    upper[50] = 1.0  # share 0: the elbow on its ray's point nearest the shoulder
    fore = np.zeros(SHARE_GRID.size)
    fore[[15, 50, 85]] = 0.45, 0.1, 0.45  # shares -0.7, 0, +0.7
    start = end(shoulder, elbow_ray, LENGTHS.upper_arm, 0.0)
    bends = [math.degrees(angle_between(start - shoulder,
                                        end(start, wrist_ray, LENGTHS.forearm, s) - start))
             for s in (-0.7, 0.7)]
    lengths = (LENGTHS.upper_arm, LENGTHS.forearm)
    flexion = math.degrees(expected_flexion(shoulder, elbow_ray, wrist_ray, lengths,
                                            (upper, fore), SHARE_FILTER))
    assert flexion == pytest.approx(np.mean(bends), abs=0.01)
    plain = math.degrees(expected_flexion(shoulder, elbow_ray, wrist_ray, lengths,
                                          (upper, fore), ShareFilter(flexion_over_tilts=2.0)))
    in_plane = math.degrees(angle_between(
        start - shoulder, end(start, wrist_ray, LENGTHS.forearm, 0.0) - start))
    assert plain == pytest.approx(in_plane, abs=0.01)
    assert flexion - plain > 5.0  # measured 32.9 against 24.5
