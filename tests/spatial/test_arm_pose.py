"""ArmPose: the arm frame, directions and flexion on hand-made arms, and the mirror rule."""

import math

import numpy as np
import pytest

from imimic_gym.spatial import ArmPose, Intrinsics, angle_between
from imimic_gym.spatial.arm_pose import MAX_ELBOW_FLEXION, unit

# A right arm of a person facing the camera 2 m away: upper arm hanging, forearm toward
# the camera (a 90-degree elbow).
RIGHT = np.array([[-0.2, 0, 2], [-0.2, 0.3, 2], [-0.2, 0.3, 1.75], [-0.2, 0.3, 1.65],
                  [0.2, 0, 2], [-0.15, 0.5, 2], [0.15, 0.5, 2]])


def pose(side: str, points: np.ndarray) -> ArmPose:
    return ArmPose(side, points, np.ones(7), np.zeros((7, 2)))


def test_arm_frame_directions_and_flexion():
    arm = pose("right", RIGHT)
    np.testing.assert_allclose(arm.arm_frame(), [[0, 0, -1], [-1, 0, 0], [0, -1, 0]],
                               atol=1e-12)
    np.testing.assert_allclose(arm.in_arm_frame(arm.upper_arm), [0, 0, -1], atol=1e-12)
    np.testing.assert_allclose(arm.in_arm_frame(arm.forearm), [1, 0, 0], atol=1e-12)
    assert arm.elbow_flexion == pytest.approx(math.pi / 2)
    np.testing.assert_allclose(arm.bone_lengths, [0.3, 0.25, 0.1])


def test_a_left_arm_is_the_mirrored_right_arm():
    mirrored = RIGHT * np.array([-1, 1, 1])
    right, left = pose("right", RIGHT), pose("left", mirrored)
    for direction in ("upper_arm", "forearm", "hand"):
        np.testing.assert_allclose(left.in_arm_frame(getattr(left, direction)),
                                   right.in_arm_frame(getattr(right, direction)), atol=1e-12)


def test_a_raised_sideways_arm_points_outward_and_up():
    points = RIGHT.copy()
    points[1] = points[0] + [-0.3 * math.cos(math.radians(30)), -0.3 * 0.5, 0]
    arm = pose("right", points)
    np.testing.assert_allclose(arm.in_arm_frame(arm.upper_arm),
                               [0, math.cos(math.radians(30)), 0.5], atol=1e-12)


def test_without_hips_up_is_the_cameras():
    points = RIGHT.copy()
    points[5:] = [[0, 5, 9], [1, 5, 9]]  # junk hips, unseen
    arm = ArmPose("right", points, np.array([1, 1, 1, 1, 1, 0.1, 0.1]), np.zeros((7, 2)))
    np.testing.assert_allclose(arm.arm_frame()[2], [0, -1, 0], atol=1e-12)


@pytest.mark.parametrize("bad", [np.nan, np.inf])
def test_non_finite_points_are_refused(bad):
    points = RIGHT.copy()
    points[2, 1] = bad
    with pytest.raises(ValueError, match=r"ArmPose\.points must be finite"):
        pose("right", points)


def test_intrinsics_round_trip():
    camera = Intrinsics.from_fovy(45, 320, 240)
    pixels = camera.project(RIGHT)
    np.testing.assert_allclose(camera.back_project(pixels, RIGHT[:, 2]), RIGHT, atol=1e-12)
    assert camera.project(np.array([0, 0, 3.0])) == pytest.approx([160, 120])


def test_unit_scales_to_length_one_and_keeps_zero_vectors_zero() -> None:
    np.testing.assert_allclose(unit(np.array([[3.0, 0, 4], [0, 0, 0], [0, 1e-13, 0]])),
                               [[0.6, 0, 0.8], [0, 0, 0], [0, 0, 0]])
    np.testing.assert_allclose(unit([0, 2e-12, 0]), [0, 1, 0])


def test_angle_between_is_exact_near_0_and_pi_and_keeps_the_batch() -> None:
    assert angle_between([1.0, 0, 0], [1.0, 1e-9, 0]) == pytest.approx(1e-9, rel=1e-6)
    assert angle_between([1.0, 0, 0], [-1.0, 1e-9, 0]) == pytest.approx(math.pi - 1e-9,
                                                                         rel=1e-12)
    assert type(angle_between([1.0, 0, 0], [0, 0, 5.0])) is float
    np.testing.assert_allclose(angle_between([[1.0, 0, 0], [0, 1, 0]], [[0, 2.0, 0], [0, 1, 0]]),
                               [math.pi / 2, 0.0])


def test_point_hand_and_the_wrists_flexion() -> None:
    points = RIGHT.copy()
    points[3] = points[2] + [0, 0.1, 0]  # the hand bent down from the forearm
    arm = pose("right", points)
    np.testing.assert_array_equal(arm.point("elbow"), points[1])
    np.testing.assert_array_equal(arm.point("other_hip"), points[6])
    np.testing.assert_allclose(arm.hand, [0, 1, 0])
    assert arm.wrist_flexion == pytest.approx(math.pi / 2)
    assert pose("right", RIGHT).wrist_flexion == pytest.approx(0.0, abs=1e-12)


def test_hips_below_half_confidence_do_not_set_up() -> None:
    points = RIGHT.copy()
    points[5:] += [0.5, 0, 0.5]  # hips off to one side and behind: a leaning torso
    leaning = unit(0.5 * (points[0] + points[4]) - 0.5 * (points[5] + points[6]))
    for hips, up in ((0.5, leaning), (0.49, np.array([0, -1.0, 0]))):
        confidence = np.array([1, 1, 1, 1, 1, hips, 1.0])
        arm = ArmPose("right", points, confidence, np.zeros((7, 2)))
        outward = arm.arm_frame()[1]
        expected = unit(up - (up @ outward) * outward)
        np.testing.assert_allclose(arm.arm_frame()[2], expected, atol=1e-12)


def test_shoulders_on_one_point_take_the_sides_own_outward() -> None:
    for side, outward in (("right", [-1.0, 0, 0]), ("left", [1.0, 0, 0])):
        points = RIGHT.copy()
        points[4] = points[0]
        frame = pose(side, points).arm_frame()
        np.testing.assert_allclose(frame[1], outward)
        np.testing.assert_allclose(frame[2], [0, -1, 0], atol=1e-12)


def test_a_torso_along_the_shoulders_line_takes_the_cameras_up() -> None:
    points = RIGHT.copy()
    points[5:] = [[0.2, 0.0, 2.0], [0.2, 0.0, 2.0]]  # hips level with the shoulders, aside
    frame = pose("right", points).arm_frame()
    np.testing.assert_allclose(frame, [[0, 0, -1], [-1, 0, 0], [0, -1, 0]], atol=1e-12)


def test_to_planar_reads_the_pixels_as_the_planar_estimators_do() -> None:
    pixels = np.zeros((7, 2))
    pixels[:3] = [[100.0, 50.0], [100.0, 80.0], [125.0, 80.0]]
    arm = ArmPose("right", RIGHT, np.ones(7), pixels)
    np.testing.assert_allclose(arm.to_planar(1), [math.pi / 2], atol=1e-12)
    np.testing.assert_allclose(arm.to_planar(2), [0.0, math.pi / 2], atol=1e-12)
    np.testing.assert_allclose(arm.to_planar(2, 0.0), [-math.pi / 2, math.pi / 2], atol=1e-12)


def test_held_keeps_the_pose_with_no_trust() -> None:
    arm = ArmPose("left", RIGHT, np.full(7, 0.9), np.ones((7, 2)), trust=0.8)
    held = arm.held()
    assert (held.side, held.trust) == ("left", 0.0)
    np.testing.assert_array_equal(held.points, arm.points)
    np.testing.assert_array_equal(held.confidence, arm.confidence)
    np.testing.assert_array_equal(held.pixels, arm.pixels)


def test_a_given_flexion_is_the_elbows_and_is_held() -> None:
    """A lift's own flexion (where it is not the bones' angle, pi / 2 here) is what
    `elbow_flexion` gives, held too; outside [0, pi] it is refused by name."""
    arm = ArmPose("right", RIGHT, np.ones(7), np.zeros((7, 2)), flexion=1.2)
    assert arm.elbow_flexion == 1.2
    assert arm.held().elbow_flexion == 1.2
    assert pose("right", RIGHT).flexion is None
    for edge in (0.0, math.pi):  # a straight arm and one folded flat are flexions too
        assert ArmPose("right", RIGHT, np.ones(7), np.zeros((7, 2)), flexion=edge).flexion == edge
    for bad in (-0.1, 3.2, math.nan):
        with pytest.raises(ValueError, match=r"ArmPose\.flexion must be None or in \[0, pi\]"):
            ArmPose("right", RIGHT, np.ones(7), np.zeros((7, 2)), flexion=bad)


def test_a_bad_side_shape_or_trust_is_refused_by_name() -> None:
    with pytest.raises(ValueError, match=r"ArmPose\.side must be 'left' or 'right', got 'up'"):
        ArmPose("up", RIGHT, np.ones(7), np.zeros((7, 2)))
    with pytest.raises(ValueError, match=r"ArmPose\.confidence must be finite with shape "
                                         r"\(7,\), got \(6,\)"):
        ArmPose("left", RIGHT, np.ones(6), np.zeros((7, 2)))
    with pytest.raises(ValueError, match=r"ArmPose\.pixels must be finite with shape "
                                         r"\(7, 2\), got \(7, 3\)"):
        ArmPose("left", RIGHT, np.ones(7), np.zeros((7, 3)))
    for trust in (-0.1, 1.1):
        with pytest.raises(ValueError, match=f"ArmPose.trust must be in \\[0, 1\\], got {trust}"):
            ArmPose("left", RIGHT, np.ones(7), np.zeros((7, 2)), trust=trust)
    edge = ArmPose("left", RIGHT.tolist(), [1] * 7, np.zeros((7, 2), np.float32), trust=1.0)
    assert edge.points.dtype == edge.confidence.dtype == edge.pixels.dtype == np.float64


def test_unit_takes_integers_and_cuts_off_at_1e_12() -> None:
    np.testing.assert_allclose(unit([0, 3, 4]), [0, 0.6, 0.8])
    np.testing.assert_array_equal(unit([1e-12, 0, 0]), [0, 0, 0])


def test_a_tilted_torso_along_the_shoulders_takes_the_cameras_up_square_to_them() -> None:
    points = RIGHT.copy()
    points[4] = [0.2, -0.4, 2.0]  # the other shoulder higher: shoulders tilted 45 degrees
    points[5:] = [[0.4, -0.6, 2.0], [0.4, -0.6, 2.0]]  # hips on the shoulders' line
    frame = pose("right", points).arm_frame()
    np.testing.assert_allclose(frame @ frame.T, np.eye(3), atol=1e-12)
    np.testing.assert_allclose(frame[1], [-math.sqrt(0.5), math.sqrt(0.5), 0], atol=1e-12)
    np.testing.assert_allclose(frame[2], [-math.sqrt(0.5), -math.sqrt(0.5), 0], atol=1e-12)


def test_an_elbow_past_an_adults_range_reads_150_degrees() -> None:
    """`within_elbow_range`: a bend past 150 degrees reads 150 (points kept); one within
    it is the same pose; a given flexion past it is read down too."""
    straight_up = RIGHT.copy()  # the forearm folded 170 degrees back up the upper arm
    fold = math.radians(170.0)
    straight_up[2] = RIGHT[1] + 0.25 * np.array([math.sin(fold), math.cos(fold), 0.0])
    folded = pose("right", straight_up)
    assert math.degrees(folded.elbow_flexion) == pytest.approx(170.0)
    within = folded.within_elbow_range()
    assert within.elbow_flexion == MAX_ELBOW_FLEXION == pytest.approx(math.radians(150.0))
    np.testing.assert_array_equal(within.points, folded.points)
    bent = pose("right", RIGHT)  # 90 degrees
    assert bent.within_elbow_range() is bent
    given = ArmPose("right", RIGHT, np.ones(7), np.zeros((7, 2)), flexion=3.0)
    assert given.within_elbow_range().elbow_flexion == MAX_ELBOW_FLEXION
