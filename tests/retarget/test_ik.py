"""Task-space retargeting through mink: round trips where the robot reaches, joint limits
for any input, smooth paths, mirrored arms."""

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from imimic_gym.retarget import robot_arm_directions
from imimic_gym.retarget.ik import MinkRetargeter
from imimic_gym.robots import SO101Spec
from imimic_gym.spatial import ArmPose, angle_between
from tests.retarget.arms import arm_pose, direction, human_arm, rotate_about

SPEC = SO101Spec()
RETARGET = MinkRetargeter(SPEC)
TOLERANCE_DEG = 0.05  # round trip where the robot reaches (IK stops within 2e-5 m)


def degrees_between(a: np.ndarray, b: np.ndarray) -> float:
    return math.degrees(float(angle_between(a, b)))


def test_robot_reachable_arms_come_back_from_a_nearby_previous_pose():
    rng = np.random.default_rng(11)
    for _ in range(60):
        q = rng.uniform(SPEC.lower, SPEC.upper)
        upper, fore = robot_arm_directions(SPEC, q)
        previous = SPEC.clip(q + rng.normal(0.0, 0.2, 6))
        target = RETARGET(arm_pose(upper, fore), previous)
        got_upper, got_fore = robot_arm_directions(SPEC, target)
        assert degrees_between(got_upper, upper) < TOLERANCE_DEG
        assert degrees_between(got_fore, fore) < TOLERANCE_DEG


def test_robot_reachable_arms_come_back_on_the_first_frame():
    rng = np.random.default_rng(12)
    for _ in range(30):
        q = rng.uniform(SPEC.lower, SPEC.upper)
        upper, fore = robot_arm_directions(SPEC, q)
        got_upper, got_fore = robot_arm_directions(SPEC, RETARGET(arm_pose(upper, fore), None))
        assert degrees_between(got_upper, upper) < TOLERANCE_DEG
        assert degrees_between(got_fore, fore) < TOLERANCE_DEG


def test_wrist_roll_and_gripper_hold_their_values():
    retarget = MinkRetargeter(SPEC, wrist_roll=0.5, gripper=1.0)
    rng = np.random.default_rng(13)
    upper, fore, _ = human_arm(rng)
    target = retarget(arm_pose(upper, fore), SPEC.clip(rng.normal(0.0, 1.0, 6)))
    np.testing.assert_allclose(target[4:], [0.5, 1.0], atol=1e-3)


finite = st.floats(-3.0, 3.0, allow_nan=False, allow_infinity=False)


@settings(max_examples=40, deadline=None)
@given(points=arrays(np.float64, (7, 3), elements=finite),
       previous=st.one_of(st.none(), arrays(np.float64, (6,), elements=st.floats(-4, 4))),
       side=st.sampled_from(["left", "right"]))
def test_targets_stay_inside_the_joint_ranges_for_any_input(points, previous, side):
    target = RETARGET(ArmPose(side, points, np.ones(7), np.zeros((7, 2))), previous)
    assert target.shape == (6,) and np.isfinite(target).all()
    assert (target >= SPEC.lower).all() and (target <= SPEC.upper).all()


def test_left_and_right_arms_mirrored_give_the_same_targets():
    rng = np.random.default_rng(14)
    for _ in range(10):
        upper, fore, _ = human_arm(rng)
        previous = SPEC.clip(rng.normal(0.0, 0.5, 6))
        right = RETARGET(arm_pose(upper, fore, side="right"), previous)
        left = RETARGET(arm_pose(upper, fore, side="left"), previous)
        np.testing.assert_allclose(left, right, atol=1e-9)


def test_smooth_motion_in_front_moves_the_joints_smoothly_and_exactly():
    # As the direction retargeter's test: a smooth wander in front, in the arm's plane.
    rng = np.random.default_rng(6)
    elevation, azimuth, flexion = 0.5, 0.0, 1.0
    targets, previous, errors = [], None, []
    for _ in range(150):
        elevation = float(np.clip(elevation + rng.normal(0, 0.012), -0.3, 1.2))
        azimuth = float(np.clip(azimuth + rng.normal(0, 0.012), -1.5, 1.5))
        flexion = float(np.clip(flexion + rng.normal(0, 0.012), 0.2, 2.4))
        upper = direction(elevation, azimuth)
        fore = rotate_about(upper, np.cross(upper, [0.0, 0.0, 1.0]), -flexion)
        previous = RETARGET(arm_pose(upper, fore), previous)
        targets.append(previous)
        got_upper, got_fore = robot_arm_directions(SPEC, previous)
        errors.append(max(degrees_between(got_upper, upper), degrees_between(got_fore, fore)))
    assert np.degrees(np.abs(np.diff(np.array(targets)[:, :4], axis=0))).max() < 4.0
    assert max(errors) < TOLERANCE_DEG
