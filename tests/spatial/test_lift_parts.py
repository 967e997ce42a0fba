"""`spatial.lift`'s parts on hand-made values: `BoneLengths`, `shoulder_depth`,
`out_of_plane`, `_solve_bone` (one bone's far end on its ray), `from_depth`'s window and
rules, `from_world_landmarks` and `neutral_pose` (test_lift.py checks the lifts whole)."""

import math

import numpy as np
import pytest

from imimic_gym.spatial import Intrinsics
from imimic_gym.spatial.lift import (
    DEFAULT_DEPTH,
    LIMB_RADIUS,
    BoneLengths,
    _solve_bone,
    from_depth,
    from_world_landmarks,
    neutral_pose,
    out_of_plane,
    shoulder_depth,
)

CAMERA = Intrinsics.from_fovy(45, 640, 480)
# Seven keypoints far apart (more than 20 px), in ARM_POINTS order.
SPREAD = np.array([[100.0, 100], [200, 100], [300, 100], [400, 100], [100, 300], [200, 300],
                   [300, 300]])


def test_bone_lengths_are_an_average_adults_and_scale_with_the_shoulders() -> None:
    average = BoneLengths()
    assert (average.shoulder_width, average.torso, average.upper_arm, average.forearm,
            average.hand) == (0.36, 0.50, 0.29, 0.25, 0.09)
    np.testing.assert_array_equal(average.arm, [0.29, 0.25, 0.09])
    wide = BoneLengths.from_shoulder_width(0.72)
    np.testing.assert_allclose([wide.shoulder_width, wide.torso, wide.upper_arm, wide.forearm,
                                wide.hand], [0.72, 1.0, 0.58, 0.5, 0.18], rtol=1e-12)
    assert BoneLengths(0.0, 0.0, 0.0, 0.0, 0.0).arm.tolist() == [0.0, 0.0, 0.0]


@pytest.mark.parametrize("name", ["shoulder_width", "torso", "upper_arm", "forearm", "hand"])
@pytest.mark.parametrize("bad", [-0.01, math.nan, math.inf])
def test_a_bone_length_that_is_not_a_length_is_refused_by_name(name: str, bad: float) -> None:
    with pytest.raises(ValueError, match=rf"^BoneLengths\.{name} must be a length in metres "
                                         rf"\(>= 0\), got {bad!r}$"):
        BoneLengths(**{name: bad})


def square_person(depth: float) -> np.ndarray:
    """Pixels of an average adult square to the camera ``depth`` m away (only the
    shoulders and hips matter here)."""
    lengths = BoneLengths()
    half, top = lengths.shoulder_width / 2, -lengths.torso / 2
    points = np.array([[-half, top, depth], [-half, 0, depth], [-half, 0.2, depth],
                       [-half, 0.3, depth], [half, top, depth], [-0.7 * half, -top, depth],
                       [0.7 * half, -top, depth]])
    return CAMERA.project(points)


def test_the_shoulder_depth_needs_confident_hips_and_stays_in_range() -> None:
    lengths = BoneLengths()
    narrow = BoneLengths(shoulder_width=0.18)  # reads the shoulders at half the depth
    pixels = square_person(3.0)
    assert shoulder_depth(pixels, np.ones(7), CAMERA, narrow) == pytest.approx(1.5)
    # A short torso reads nearer than the width, with hips at 0.5 confidence and above.
    short = BoneLengths(torso=0.25)
    hips_half = np.array([1, 1, 1, 1, 1, 0.5, 0.5])
    assert shoulder_depth(pixels, hips_half, CAMERA, short) == pytest.approx(1.5)
    assert shoulder_depth(pixels, hips_half, CAMERA, short, min_confidence=0.6) == \
        pytest.approx(3.0)
    assert shoulder_depth(pixels, np.array([1, 1, 1, 1, 1, 0.5, 0.4]), CAMERA, short) == \
        pytest.approx(3.0)
    # Neither length known: the default; far too wide or too narrow: the range's ends.
    none = BoneLengths(shoulder_width=0.0, torso=0.0)
    assert shoulder_depth(pixels, np.ones(7), CAMERA, none) == DEFAULT_DEPTH
    assert shoulder_depth(pixels, np.ones(7), CAMERA, BoneLengths(shoulder_width=0.0)) == \
        pytest.approx(3.0)
    assert shoulder_depth(square_person(0.05), np.zeros(7), CAMERA, lengths) == 0.2
    assert shoulder_depth(square_person(500.0), np.zeros(7), CAMERA, lengths) == 50.0


def expected_share(ratio: float, noise: float) -> float:
    """`out_of_plane` by fine quadrature: the mean share s, uniform on [0, 1], weighed
    by the chance of measuring ``ratio`` from sqrt(1 - s^2)."""
    share = np.linspace(0.0, 1.0, 200_001)
    weights = np.exp(-0.5 * ((ratio - np.sqrt(1 - share ** 2)) / noise) ** 2)
    return float(weights @ share / weights.sum())


@pytest.mark.parametrize("ratio", [0.3, 0.7, 0.95, 1.0, 1.05])
def test_out_of_plane_is_the_mean_share_given_the_noisy_ratio(ratio: float) -> None:
    assert out_of_plane(ratio, 0.04) == pytest.approx(expected_share(ratio, 0.04), abs=2e-3)
    assert out_of_plane(ratio, 0.1) == pytest.approx(expected_share(ratio, 0.1), abs=2e-3)


def test_out_of_plane_without_noise_is_taylors_and_has_its_limits() -> None:
    assert out_of_plane(0.0, 0.0) == 1.0
    assert out_of_plane(0.8, 0.0) == pytest.approx(0.6, abs=1e-15)
    assert out_of_plane(1.0, -0.1) == 0.0
    assert out_of_plane(0.0, 0.01) == 0.999  # never quite along the line of sight
    # A reading no bone could give (every weight 0): the nearest reading's share.
    assert out_of_plane(-0.5, 0.001) == pytest.approx(math.sqrt(0.75))
    assert out_of_plane(1.5, 0.001) == 0.0


START = np.array([0.0, 0.0, 2.0])
RAY = np.array([0.1, 0.0, 1.0])  # the far end's pixel's ray, z = 1


def roots(length: float) -> tuple[float, float, float]:
    """(near t, far t, the lower bound) of t * RAY at ``length`` from START, by hand."""
    a = RAY @ RAY
    middle = RAY @ START / a
    lower = math.sqrt(START @ START - a * middle ** 2)
    half = math.sqrt(middle ** 2 - (START @ START - length ** 2) / a)
    return middle - half, middle + half, lower


def test_a_bone_takes_the_root_toward_the_camera_unless_told_otherwise() -> None:
    near, far, lower = roots(0.5)
    bone = _solve_bone(START, RAY, 0.5, None, None, 0.25)
    np.testing.assert_allclose(bone.end, near * RAY, atol=1e-12)
    assert np.linalg.norm(bone.end - START) == pytest.approx(0.5, abs=1e-12)
    assert bone.lower_bound == pytest.approx(lower, abs=1e-12)
    assert (bone.missed, bone.overruled) == (False, False)
    # The model's depth of the far end behind the roots' middle: away.
    middle = 0.5 * (near + far)
    away = _solve_bone(START, RAY, 0.5, middle - 2.0 + 0.1, None, 0.25)
    np.testing.assert_allclose(away.end, far * RAY, atol=1e-12)
    toward = _solve_bone(START, RAY, 0.5, middle - 2.0 - 0.1, None, 0.25)
    np.testing.assert_allclose(toward.end, near * RAY, atol=1e-12)


def test_continuity_picks_the_root_only_where_the_model_is_unsure() -> None:
    near, far, _ = roots(0.5)
    middle, half_gap = 0.5 * (near + far), 0.5 * (far - near)
    previous_away = (far * RAY - START) / np.linalg.norm(far * RAY - START)
    slightly_toward = middle - 2.0 - 0.2 * half_gap  # inside 0.25 of the half gap
    bone = _solve_bone(START, RAY, 0.5, slightly_toward, previous_away, 0.25)
    np.testing.assert_allclose(bone.end, far * RAY, atol=1e-12)
    clearly_toward = middle - 2.0 - 0.3 * half_gap
    bone = _solve_bone(START, RAY, 0.5, clearly_toward, previous_away, 0.25)
    np.testing.assert_allclose(bone.end, near * RAY, atol=1e-12)
    # The margin (metres) widens "unsure" beyond the threshold's share.
    bone = _solve_bone(START, RAY, 0.5, clearly_toward, previous_away, 0.25,
                       sign_margin=0.31 * half_gap)
    np.testing.assert_allclose(bone.end, far * RAY, atol=1e-12)


def test_the_turn_limit_overrules_the_model_for_a_bone_out_of_the_image_plane() -> None:
    near, far, _ = roots(0.5)
    middle = 0.5 * (near + far)
    toward = (near * RAY - START) / np.linalg.norm(near * RAY - START)  # z about -0.92
    says_away = middle - 2.0 + 0.2
    bone = _solve_bone(START, RAY, 0.5, says_away, toward, 0.25, max_turn=0.5)
    np.testing.assert_allclose(bone.end, near * RAY, atol=1e-12)
    assert bone.overruled
    free = _solve_bone(START, RAY, 0.5, says_away, toward, 0.25, max_turn=math.pi)
    np.testing.assert_allclose(free.end, far * RAY, atol=1e-12)
    assert not free.overruled
    # A previous direction near the image plane (|z| at most 0.5) is no flip to refuse.
    flat = np.array([math.sqrt(0.75), 0.0, -0.5])
    bone = _solve_bone(START, RAY, 0.5, says_away, flat, 0.25, max_turn=0.01)
    np.testing.assert_allclose(bone.end, far * RAY, atol=1e-12)


def test_a_bone_too_short_for_its_ray_lies_in_the_image_plane() -> None:
    _, _, lower = roots(0.5)
    bone = _solve_bone(START, RAY, 0.9 * lower, -1.0, None, 0.25)
    middle = RAY @ START / (RAY @ RAY)
    np.testing.assert_allclose(bone.end, middle * RAY, atol=1e-12)
    assert bone.missed and bone.lower_bound == pytest.approx(lower, abs=1e-12)
    assert abs((bone.end - START) @ RAY) < 1e-12


def test_with_the_camera_inside_the_bone_only_the_far_root_is_real() -> None:
    start = np.array([0.0, 0.0, 0.3])
    bone = _solve_bone(start, np.array([0.0, 0.0, 1.0]), 0.5, -1.0, None, 0.25)
    np.testing.assert_allclose(bone.end, [0.0, 0.0, 0.8], atol=1e-12)


def test_with_noise_the_bone_tilts_out_of_the_plane_by_the_expected_share() -> None:
    _, _, lower = roots(0.5)
    ratio = lower / 0.5
    bone = _solve_bone(START, RAY, 0.5, None, None, 0.25, noise=0.04)
    middle = RAY @ START / (RAY @ RAY)
    share = out_of_plane(ratio, 0.04)
    along = np.linalg.norm(bone.end - middle * RAY)  # the extent along the line of sight
    assert along / lower == pytest.approx(share / math.sqrt(1 - share ** 2), rel=1e-9)
    assert bone.end[2] < middle * RAY[2]  # toward the camera without the model's order


@pytest.mark.parametrize("side", ["left", "right"])
def test_the_neutral_pose_is_the_average_adult_hanging_its_arms(side: str) -> None:
    out = 1.0 if side == "left" else -1.0
    pose = neutral_pose(side, CAMERA)
    np.testing.assert_allclose(pose.points, [
        [0.18 * out, -0.25, 2.5], [0.18 * out, 0.04, 2.5], [0.18 * out, 0.29, 2.5],
        [0.18 * out, 0.38, 2.5], [-0.18 * out, -0.25, 2.5], [0.126 * out, 0.25, 2.5],
        [-0.126 * out, 0.25, 2.5]], atol=1e-12)
    np.testing.assert_allclose(pose.pixels, CAMERA.project(pose.points), atol=1e-9)
    near = neutral_pose(side, CAMERA, BoneLengths.from_shoulder_width(0.72), depth=1.0)
    np.testing.assert_allclose(near.points[:, 2], 1.0)
    np.testing.assert_allclose(near.points[1] - near.points[0], [0, 0.58, 0], atol=1e-12)
    with pytest.raises(ValueError, match=r"^side must be 'left' or 'right', got 'up'$"):
        neutral_pose("up", CAMERA)


def test_world_landmarks_take_the_lengths_depth_clip_it_and_the_least_arm_trust() -> None:
    pixels = square_person(3.0)
    world = CAMERA.back_project(pixels, np.full(7, 3.0))  # square to the camera, 3 m
    confidence = np.array([0.9, 0.8, 0.7, 0.1, 0.2, 0.3, 0.4])
    pose = from_world_landmarks("right", world - world[5], pixels, confidence, CAMERA)
    np.testing.assert_allclose(pose.points, world, atol=1e-9)
    assert pose.trust == 0.7 and pose.side == "right"
    np.testing.assert_array_equal(pose.confidence, confidence)
    doubled = from_world_landmarks("right", world, pixels, confidence, CAMERA,
                                   lengths=BoneLengths.from_shoulder_width(0.72))
    assert doubled.points[0, 2] == pytest.approx(6.0)
    assert from_world_landmarks("right", world, pixels, confidence, CAMERA,
                                depth_of_shoulder=500.0).points[0, 2] == pytest.approx(50.0)


def test_from_depth_reads_a_window_of_one_percent_of_the_diagonal() -> None:
    """Only the shoulder's window rows 8 and 9 above it hold depths: 3.0 at 8 (inside
    the default window, 8 px on 640x480), 1.0 at 9 (outside)."""
    image = np.zeros((480, 640))
    col, row = 100, 100
    image[row - 8, col - 8:col + 9] = 3.0
    image[row - 9, col - 9:col + 10] = 1.0
    pose = from_depth("right", SPREAD, np.ones(7), image, CAMERA)
    assert pose.points[0, 2] == pytest.approx(3.0 + LIMB_RADIUS[0])
    # The others found nothing: the median of the depths found, confidence 0.
    np.testing.assert_allclose(pose.points[1:, 2], 3.0 + LIMB_RADIUS[0])
    np.testing.assert_array_equal(pose.confidence, [1, 0, 0, 0, 0, 0, 0])
    assert pose.trust == 0.0
    assert from_depth("right", SPREAD, np.ones(7), image, CAMERA, window=9).points[0, 2] == \
        pytest.approx(1.0 + LIMB_RADIUS[0])


def test_from_depth_adds_each_limbs_radius_and_sends_a_shoulder_on_the_wall_forward() -> None:
    np.testing.assert_array_equal(LIMB_RADIUS, [0.05, 0.04, 0.03, 0.015, 0.05, 0.08, 0.08])

    def image_with(shoulder: float) -> np.ndarray:
        image = np.zeros((480, 640))
        for (x, y), z in zip(SPREAD.astype(int), [shoulder] + [2.0] * 6, strict=True):
            image[y - 2:y + 3, x - 2:x + 3] = z
        return image

    pose = from_depth("right", SPREAD, np.ones(7), image_with(2.25), CAMERA, window=2)
    np.testing.assert_allclose(pose.points[:, 2], 2.0 + LIMB_RADIUS
                               + [0.25, 0, 0, 0, 0, 0, 0], atol=1e-12)
    np.testing.assert_allclose(pose.points, CAMERA.back_project(SPREAD, pose.points[:, 2]))
    # Over 0.3 m behind the elbow's, other shoulder's and hips' median (2.065, their
    # radii added): the wall; the median takes its place.
    wall = from_depth("right", SPREAD, np.ones(7), image_with(2.40), CAMERA, window=2)
    assert wall.points[0, 2] == pytest.approx(2.065)
    kept = from_depth("right", SPREAD, np.ones(7), image_with(2.31), CAMERA, window=2)
    assert kept.points[0, 2] == pytest.approx(2.36)


def test_from_depth_sends_a_shoulder_with_a_hand_before_it_back_to_the_torso() -> None:
    """A hand raised before the shoulder (a curl toward the camera): the shoulder's window
    reads the hand. Over 0.15 m in front of both its own hip and the other shoulder, it
    takes the nearer of their depths; a lean (in front of its hip alone) or a turn (in
    front of the other shoulder alone) is kept, and so is a reading of unsure ones."""
    def image_with(depths: list[float]) -> np.ndarray:
        image = np.zeros((480, 640))
        for (x, y), z in zip(SPREAD.astype(int), depths, strict=True):
            image[y - 2:y + 3, x - 2:x + 3] = z
        return image

    # shoulder, elbow, wrist, hand, other shoulder, hip, other hip
    hand = from_depth("right", SPREAD, np.ones(7),
                      image_with([1.7, 2.0, 2.0, 2.0, 2.0, 2.05, 2.0]), CAMERA, window=2)
    assert hand.points[0, 2] == pytest.approx(2.0 + LIMB_RADIUS[4])  # the other shoulder's
    near = from_depth("right", SPREAD, np.ones(7),
                      image_with([1.9, 2.0, 2.0, 2.0, 2.0, 2.0, 2.0]), CAMERA, window=2)
    assert near.points[0, 2] == pytest.approx(1.9 + LIMB_RADIUS[0])  # within 0.15: kept
    lean = from_depth("right", SPREAD, np.ones(7),
                      image_with([1.7, 1.8, 1.8, 1.8, 1.75, 2.0, 2.0]), CAMERA, window=2)
    assert lean.points[0, 2] == pytest.approx(1.7 + LIMB_RADIUS[0])
    turn = from_depth("right", SPREAD, np.ones(7),
                      image_with([1.7, 1.8, 1.8, 1.8, 2.0, 1.72, 2.0]), CAMERA, window=2)
    assert turn.points[0, 2] == pytest.approx(1.7 + LIMB_RADIUS[0])
    unsure = np.ones(7)
    unsure[[4, 5]] = 0.3
    kept = from_depth("right", SPREAD, unsure,
                      image_with([1.7, 2.0, 2.0, 2.0, 2.0, 2.05, 2.0]), CAMERA, window=2)
    assert kept.points[0, 2] == pytest.approx(1.7 + LIMB_RADIUS[0])


def test_from_depth_solves_a_bone_off_its_length_beyond_the_tolerance() -> None:
    """An arm square to the camera, 2 m away; the depth camera reads the wrist ``behind``
    m too deep (the wall behind it): its forearm 21% too long is kept, 50%
    too long is solved on the wrist's ray at the forearm's length, away as measured."""
    elbow = np.array([0.0, 0.29, 2.0])
    points = np.array([[0.0, 0.0, 2.0], elbow, [0.25, 0.29, 2.0], [0.34, 0.29, 2.0],
                       [0.36, 0, 2.0], [0.05, 0.5, 2.0], [0.3, 0.5, 2.0]])
    pixels = CAMERA.project(points)
    for behind, solved in ((0.142, False), (0.245, True)):
        image = np.zeros((480, 640))
        for i, ((x, y), z, radius) in enumerate(zip(pixels, points[:, 2], LIMB_RADIUS,
                                                    strict=True)):
            col, row = round(x), round(y)
            image[row - 1:row + 2, col - 1:col + 2] = z - radius + (behind if i == 2 else 0)
        pose = from_depth("right", pixels, np.ones(7), image, CAMERA, window=1,
                          lengths=np.array([0.29, 0.25, 0.09]))
        forearm = np.linalg.norm(pose.points[2] - pose.points[1])
        measured = np.linalg.norm(CAMERA.back_project(pixels[2], 2.0 + behind) - elbow)
        assert forearm == pytest.approx(0.25 if solved else measured, abs=1e-6)
        assert pose.confidence[2] == 1.0


def test_the_adapters_clip_confidences_and_refuse_bad_keypoints_by_name() -> None:
    """`from_world_landmarks` and `from_depth` check their keypoints as the lift does."""
    pixels = square_person(3.0)
    world = CAMERA.back_project(pixels, np.full(7, 3.0))
    confidence = np.array([1.5, 0.9, 0.8, -0.2, 1.0, 1.0, 1.0])
    pose = from_world_landmarks("left", world, pixels.tolist(), confidence, CAMERA)
    np.testing.assert_array_equal(pose.confidence, [1.0, 0.9, 0.8, 0.0, 1.0, 1.0, 1.0])
    assert pose.trust == 0.8
    with pytest.raises(ValueError, match=r"^a lift needs pixels \(7, 2\) and confidence "
                                         r"\(7,\), got \(7, 2\) and \(6,\)$"):
        from_world_landmarks("left", world, pixels, np.ones(6), CAMERA)
    with pytest.raises(ValueError, match=r"^a lift needs finite pixels and confidences$"):
        from_world_landmarks("left", world, pixels, np.r_[np.ones(6), np.nan], CAMERA)
    with pytest.raises(ValueError, match=r"^world landmarks must be finite with shape \(7, 3\), "
                                         r"got \(7, 3\)$"):
        from_world_landmarks("left", np.full((7, 3), np.inf), pixels, np.ones(7), CAMERA)
    with pytest.raises(ValueError, match=r"^from_depth: the depth image is \(10, 10\), the "
                                         r"intrinsics are for \(480, 640\)$"):
        from_depth("left", pixels, np.ones(7), np.ones((10, 10)), CAMERA)
