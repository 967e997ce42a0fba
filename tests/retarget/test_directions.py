"""Direction retargeting: round trips through the robot's forward kinematics, the least
cost against a grid search, the nearest reachable direction, a wave's forearm, joint limits
for any input, continuity along paths, mirrored arms."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from imimic_gym.retarget import TILTED, DirectionRetargeter, robot_arm_directions
from imimic_gym.robots import SO101Spec
from imimic_gym.spatial import ArmPose, angle_between, unit
from tests.retarget.arms import arm_pose, direction, human_arm, rotate_about

SPEC = SO101Spec()
RETARGET = DirectionRetargeter(SPEC)
# The upper arm alone, as near as the robot reaches; the forearm and flexion do not count.
UPPER_ONLY = DirectionRetargeter(SPEC, forearm_weight=0.0, flexion_weight=0.0)
# Both directions' plain squared errors, a hanging upper arm's horizontal part as it is.
PLAIN = DirectionRetargeter(SPEC, hanging_power=0.0)
EXACT_DEG = 0.01  # round-trip tolerance where the robot can reach, degrees
# The upper arm's elevation in the arm's plane at shoulder_lift 0 (the model's 0.028 m
# forward, 0.11257 m up from the lift axis to the elbow axis).
UPPER_AT_ZERO = math.atan2(0.11257, 0.028)
PAN_LIMIT = SPEC.joint_ranges[0][1]
LIFT_LIMIT = SPEC.joint_ranges[1][1]


def degrees_between(a: np.ndarray, b: np.ndarray) -> float:
    return math.degrees(float(angle_between(a, b)))


def reachable(upper: np.ndarray, margin: float = math.radians(0.5)) -> bool:
    """Whether some pan and lift in range point the upper arm along ``upper`` (arm frame
    = robot frame under the mirror mapping), with ``margin`` rad to spare."""
    elevation = math.asin(float(np.clip(upper[2], -1, 1)))
    pan = -math.atan2(upper[1], upper[0])
    front = abs(pan) <= PAN_LIMIT - margin and \
        elevation >= UPPER_AT_ZERO - LIFT_LIMIT + margin
    back_pan = math.pi - abs(pan)
    back = back_pan <= PAN_LIMIT - margin and \
        math.pi - elevation <= UPPER_AT_ZERO + LIFT_LIMIT - margin
    return front or back


def test_every_robot_reachable_arm_comes_back_exactly():
    rng = np.random.default_rng(1)
    for _ in range(300):
        q = rng.uniform(SPEC.lower, SPEC.upper)
        upper, fore = robot_arm_directions(SPEC, q)
        target = RETARGET(arm_pose(upper, fore), None)
        got_upper, got_fore = robot_arm_directions(SPEC, target)
        assert degrees_between(got_upper, upper) < EXACT_DEG
        assert degrees_between(got_fore, fore) < EXACT_DEG


def bend_at_zero() -> float:
    """Rad: the robot's forearm's bend from its upper arm (forward-down positive) at q = 0,
    from forward kinematics."""
    upper, fore = robot_arm_directions(SPEC, np.zeros(6))
    return math.atan2(upper[2], upper[0]) - math.atan2(fore[2], fore[0])


def grid_cost(retarget: DirectionRetargeter, upper: np.ndarray, fore: np.ndarray) -> float:
    """The least cost (``e_upper^2 + forearm_weight e_forearm^2 + flexion_weight
    (robot flexion - flexion)^2``, rad^2) over a grid of robot arms: pans 2 degrees apart,
    upper-arm elevations in the arm's plane 1 degree apart, bends 1 degree apart, over
    the joint ranges (at least the true least cost)."""
    elbow_limit = SPEC.joint_ranges[2][1]
    pans = np.linspace(-PAN_LIMIT, PAN_LIMIT, 111)
    elevations = np.linspace(UPPER_AT_ZERO - LIFT_LIMIT, UPPER_AT_ZERO + LIFT_LIMIT, 201)
    bends = np.linspace(bend_at_zero() - elbow_limit, bend_at_zero() + elbow_limit, 195)
    flexion = float(angle_between(upper, fore))
    best = math.inf
    for pan in pans:
        across_upper = math.cos(pan) * upper[0] - math.sin(pan) * upper[1]
        across_fore = math.cos(pan) * fore[0] - math.sin(pan) * fore[1]
        e_upper = np.arccos(np.clip(np.cos(elevations) * across_upper
                                    + np.sin(elevations) * upper[2], -1, 1))[:, None]
        fore_elevations = elevations[:, None] - bends[None, :]
        e_fore = np.arccos(np.clip(np.cos(fore_elevations) * across_fore
                                   + np.sin(fore_elevations) * fore[2], -1, 1))
        cost = (e_upper ** 2 + retarget.forearm_weight * e_fore ** 2
                + retarget.flexion_weight * (np.abs(bends)[None, :] - flexion) ** 2)
        best = min(best, float(cost.min()))
    return best


def robot_cost(retarget: DirectionRetargeter, q: np.ndarray, upper: np.ndarray,
               fore: np.ndarray) -> float:
    """The same cost for the robot's arm at ``q``, from forward kinematics."""
    got_upper, got_fore = robot_arm_directions(SPEC, q)
    flexion_error = float(angle_between(got_upper, got_fore) - angle_between(upper, fore))
    return (float(angle_between(got_upper, upper)) ** 2
            + retarget.forearm_weight * float(angle_between(got_fore, fore)) ** 2
            + retarget.flexion_weight * flexion_error ** 2)


def aimed(retarget: DirectionRetargeter, upper: np.ndarray) -> np.ndarray:
    """The upper arm the cost is taken on: below the robot's lowest elevation, its
    horizontal part times (its length / that elevation's cosine) ** hanging_power."""
    lowest = UPPER_AT_ZERO - LIFT_LIMIT
    if upper[2] >= math.sin(lowest):
        return upper
    shrink = (math.hypot(upper[0], upper[1]) / math.cos(lowest)) ** retarget.hanging_power
    aim = np.array([upper[0] * shrink, upper[1] * shrink, upper[2]])
    return aim / np.linalg.norm(aim)


@pytest.mark.parametrize("retarget", [RETARGET, UPPER_ONLY, PLAIN],
                         ids=["default", "upper-only", "plain"])
def test_human_arms_get_the_best_arm_the_robot_can_take(retarget):
    rng = np.random.default_rng(2)
    for _ in range(15):
        upper, fore, _ = human_arm(rng)
        target = retarget(arm_pose(upper, fore), None)
        aim = aimed(retarget, upper)
        assert robot_cost(retarget, target, aim, fore) <= grid_cost(retarget, aim, fore) + 1e-6


def nearest_reachable_error(upper: np.ndarray) -> float:
    """Degrees from ``upper`` to the nearest robot upper arm on a 0.5-degree grid of pan
    and lift (at least the true nearest's)."""
    pans = np.radians(np.arange(-110, 110.01, 0.5))[:, None]
    elevations = UPPER_AT_ZERO - np.radians(np.arange(-100, 100.01, 0.5))[None, :]
    directions = np.stack(np.broadcast_arrays(np.cos(elevations) * np.cos(pans),
                                              -np.cos(elevations) * np.sin(pans),
                                              np.sin(elevations)), axis=-1)
    return float(np.degrees(np.min(angle_between(directions, upper))))


def test_an_unreachable_upper_arm_gets_the_nearest_reachable_direction():
    rng = np.random.default_rng(3)
    cases = [direction(-math.pi / 2, 0.0), direction(math.radians(-60), math.radians(30)),
             direction(math.radians(-10), math.radians(150))]
    while len(cases) < 40:
        upper, _, _ = human_arm(rng)
        if not reachable(upper, margin=0.0):
            cases.append(upper)
    for upper in cases:
        got_upper, _ = robot_arm_directions(SPEC, UPPER_ONLY(arm_pose(upper, upper), None))
        assert degrees_between(got_upper, upper) <= nearest_reachable_error(upper) + 0.01


def test_a_hanging_arm_lowers_the_robots_upper_arm_to_its_limit_and_holds_the_pan():
    hanging = direction(-math.pi / 2, 0.0)
    start = np.radians([30.0, 40.0, 0.0, 0.0, 0.0, 0.0])
    target = start
    for _ in range(10):  # the lift moves at most max_step a frame
        target = RETARGET(arm_pose(hanging, hanging), target)
    assert target[1] == pytest.approx(LIFT_LIMIT)
    assert target[0] == pytest.approx(start[0])


def test_a_hanging_upper_arms_slight_tilt_leaves_the_pan_to_the_forearm():
    """A curl: the upper arm hangs 25 degrees off vertical, tilted back and out or forward
    (an estimate's error near the pole is that large), the forearm points forward. The
    robot's upper arm cannot hang that low; its pan follows the forearm whichever way the
    upper arm tilts, where the plain cost lets the tilt turn it."""
    back, forward = unit(np.array([-0.26, 0.34, -0.91])), unit(np.array([0.19, 0.20, -0.96]))
    fore = unit(np.array([0.98, 0.11, -0.14]))

    def settled(retarget: DirectionRetargeter, upper: np.ndarray) -> np.ndarray:
        target = None
        for _ in range(30):  # each joint moves at most max_step a frame
            target = retarget(arm_pose(upper, fore), target)
        return target

    pans = {}
    for name, retarget in (("default", RETARGET), ("plain", PLAIN)):
        targets = [settled(retarget, upper) for upper in (back, forward)]
        pans[name] = math.degrees(abs(targets[0][0] - targets[1][0]))
        if retarget is RETARGET:
            for target in targets:
                assert degrees_between(robot_arm_directions(SPEC, target)[1], fore) < 10.0
    # measured: 5.2 degrees apart by default, 20.6 with the plain cost
    assert pans["default"] < 8.0 < 15.0 < pans["plain"]


def test_the_tilted_mapping_brings_a_hanging_arm_into_reach():
    hanging = direction(-math.pi / 2, 0.0)
    tilted = DirectionRetargeter(SPEC, mapping=TILTED)
    got_upper, got_fore = robot_arm_directions(SPEC, tilted(arm_pose(hanging, hanging), None),
                                               TILTED)
    assert degrees_between(got_upper, hanging) < 0.1
    assert degrees_between(got_fore, hanging) < 0.1


def test_the_wrist_follows_the_hand_in_the_arms_plane():
    rng = np.random.default_rng(4)
    for _ in range(100):
        q = rng.uniform(SPEC.lower, SPEC.upper)
        q[4:] = 0.0
        upper, fore = robot_arm_directions(SPEC, q)
        # The robot's hand turns from its forearm by wrist_flex about the wrist's axis,
        # the robot's y axis turned by the pan about -z.
        wrist_axis = np.array([math.sin(q[0]), math.cos(q[0]), 0.0])
        hand = rotate_about(fore, wrist_axis, q[3])
        target = RETARGET(arm_pose(upper, fore, hand), None)
        if abs(target[0] - q[0]) < 1e-9 and abs(target[2] - q[2]) < 1e-9:
            assert math.degrees(abs(target[3] - q[3])) < EXACT_DEG


def test_left_and_right_arms_mirrored_give_the_same_targets():
    rng = np.random.default_rng(5)
    for _ in range(50):
        upper, fore, _ = human_arm(rng)
        hand = rotate_about(fore, np.cross(upper, fore) + 1e-3, 0.3)
        right = RETARGET(arm_pose(upper, fore, hand, "right"), None)
        left = RETARGET(arm_pose(upper, fore, hand, "left"), None)
        np.testing.assert_allclose(left, right, atol=1e-9)


finite = st.floats(-3.0, 3.0, allow_nan=False, allow_infinity=False)


@settings(max_examples=150, deadline=None)
@given(points=arrays(np.float64, (7, 3), elements=finite),
       previous=st.one_of(st.none(), arrays(np.float64, (6,), elements=st.floats(-4, 4))),
       side=st.sampled_from(["left", "right"]))
def test_targets_stay_inside_the_joint_ranges_for_any_input(points, previous, side):
    pose = ArmPose(side, points, np.ones(7), np.zeros((7, 2)))
    target = RETARGET(pose, previous)
    assert target.shape == (6,) and np.isfinite(target).all()
    assert (target >= SPEC.lower).all() and (target <= SPEC.upper).all()


def follow(path: list[ArmPose], retarget: DirectionRetargeter = RETARGET) -> np.ndarray:
    """(T, 6) targets along ``path``, each frame given the last."""
    targets, previous = [], None
    for pose in path:
        previous = retarget(pose, previous)
        targets.append(previous)
    return np.array(targets)


def great_circle(start: np.ndarray, end: np.ndarray, step_deg: float) -> list[np.ndarray]:
    total = math.degrees(float(angle_between(start, end)))
    axis = np.cross(start, end)
    return [rotate_about(start, axis, math.radians(a))
            for a in np.arange(0.0, total + 1e-9, step_deg)]


# A path step of 1 degree a frame (a brisk 30 degrees a second at 30 fps).
STEP_DEG = 1.0
MAX_STEP_DEG = math.degrees(RETARGET.max_step)


@pytest.mark.parametrize(("miss_deg", "max_error_deg"), [(0.0, EXACT_DEG), (1.0, 5.0),
                                                         (3.0, 30.0)])
def test_no_flip_through_or_past_the_pole(miss_deg, max_error_deg):
    # The upper arm swings up over the top, from forward to backward (its closest to the
    # pole about 2.7 times miss_deg), the elbow bent 60 degrees in the swing's plane.
    start = direction(math.radians(20), math.radians(miss_deg))
    end = direction(math.radians(20), math.pi - math.radians(miss_deg))
    normal = np.cross(start, end)
    path = [arm_pose(upper, rotate_about(upper, normal, -math.radians(60)))
            for upper in great_circle(start, end, STEP_DEG)]
    targets = follow(path)
    assert np.degrees(np.abs(np.diff(targets, axis=0))).max() <= MAX_STEP_DEG + 1e-9
    errors = [degrees_between(robot_arm_directions(SPEC, q)[0], pose.in_arm_frame(
        pose.upper_arm)) for q, pose in zip(targets, path, strict=True)]
    # Through the pole the pan holds and nothing is lost; passing beside it the robot's
    # pan must swing half a turn (to reach over the top) while the person's upper arm
    # turns about the pole: it lags for a few frames.
    assert max(errors) < max_error_deg
    # Then it has caught up: where the frame alone puts it (the swing's plane leans off
    # the vertical, so both segments are not exact at once).
    alone = robot_arm_directions(SPEC, RETARGET(path[-1], None))[0]
    assert degrees_between(robot_arm_directions(SPEC, targets[-1])[0], alone) < 0.1


def test_no_flip_along_the_limits():
    # The upper arm sweeps sideways from forward to behind (past the pan limit) at the
    # horizon, then drops to hanging (past the lift limit) and comes back up forward.
    path_dirs = great_circle(direction(0.0, 0.0), direction(0.0, math.radians(170)), STEP_DEG)
    path_dirs += great_circle(path_dirs[-1], direction(-math.pi / 2, 0.0), STEP_DEG)
    path_dirs += great_circle(path_dirs[-1], direction(0.0, math.radians(-20)), STEP_DEG)
    path = [arm_pose(u, rotate_about(u, np.cross(u, [0.0, 0.0, 1.0]) + 1e-6, -0.8))
            for u in path_dirs]
    targets = follow(path)
    jumps = np.degrees(np.abs(np.diff(targets, axis=0)))
    assert jumps.max() <= MAX_STEP_DEG + 1e-9
    assert (targets >= SPEC.lower).all() and (targets <= SPEC.upper).all()


def test_smooth_motion_in_front_moves_the_joints_smoothly_and_exactly():
    # A smooth random wander of the upper arm in front of the person, above the robot's
    # lowest reach and away from the pole, the elbow bending forward-down in the arm's
    # plane: the joints move about as fast as the arm, never at the step limit, and the
    # upper arm and forearm stay exact.
    rng = np.random.default_rng(6)
    elevation, azimuth, flexion = 0.5, 0.0, 1.0
    path = []
    for _ in range(300):
        elevation = float(np.clip(elevation + rng.normal(0, 0.012), -0.3, 1.2))
        azimuth = float(np.clip(azimuth + rng.normal(0, 0.012), -1.5, 1.5))
        flexion = float(np.clip(flexion + rng.normal(0, 0.012), 0.2, 2.4))
        upper = direction(elevation, azimuth)
        normal = np.cross(upper, [0.0, 0.0, 1.0])
        path.append(arm_pose(upper, rotate_about(upper, normal, -flexion)))
    targets = follow(path)
    assert np.degrees(np.abs(np.diff(targets, axis=0))).max() < 4.0
    errors = [max(degrees_between(got, pose.in_arm_frame(wanted)) for got, wanted in zip(
        robot_arm_directions(SPEC, q), (pose.upper_arm, pose.forearm), strict=True))
        for q, pose in zip(targets, path, strict=True)]
    assert max(errors) < 0.1


# Arm-frame directions of a wave: the upper arm straight outward, the forearm up.
OUTWARD = direction(0.0, math.pi / 2)
UP = direction(math.pi / 2, 0.0)
# Degrees the robot's upper arm misses straight outward when it reaches over the top (the
# lift's limit): its elevation in the arm's plane goes no higher than this short of 180.
OVER_THE_TOP_SHORT_DEG = 180.0 - math.degrees(UPPER_AT_ZERO + LIFT_LIMIT)


def test_a_wave_reaches_over_the_top_to_point_the_forearm_up():
    # Pointing the upper arm straight outward leaves the forearm no higher than 23
    # degrees above it (the elbow bends back-up no further); the robot's other shoulder
    # solution, pan turned half a turn and the upper arm over the top, misses outward by
    # 4 degrees and points the forearm up.
    got_upper, got_fore = robot_arm_directions(SPEC, RETARGET(arm_pose(OUTWARD, UP), None))
    assert degrees_between(got_fore, UP) < 2.0
    assert degrees_between(got_upper, OUTWARD) < OVER_THE_TOP_SHORT_DEG + 2.0
    # With the upper arm alone counting, it stays straight outward.
    got_upper, _ = robot_arm_directions(SPEC, UPPER_ONLY(arm_pose(OUTWARD, UP), None))
    assert degrees_between(got_upper, OUTWARD) < EXACT_DEG


def waving_arm() -> tuple[list[ArmPose], list[ArmPose]]:
    """The arm rises sideways from hanging to outward, the elbow bending the forearm up
    as it goes (40 frames), holds (20 frames); then (the second list) the forearm waves
    30 degrees to either side of up in the body's plane, once a second for three
    seconds."""
    path = []
    for i in range(40):
        rise = (i + 1) / 40 * math.pi / 2
        upper = direction(rise - math.pi / 2, math.pi / 2)
        path.append(arm_pose(upper, direction(2 * rise - math.pi / 2, math.pi / 2)))
    path += [arm_pose(OUTWARD, UP)] * 20
    waving = []
    for i in range(90):
        sway = math.radians(30) * math.sin(2 * math.pi * i / 30)
        fore = direction(math.pi / 2 - abs(sway), math.pi / 2 if sway >= 0 else -math.pi / 2)
        waving.append(arm_pose(OUTWARD, fore))
    return path, waving


def test_a_waving_forearm_keeps_the_shoulder_in_front_by_default():
    # The over-the-top solution points the forearm up but lies a swing of half a turn of
    # the pan away; by default (`jump_cost`) the robot does not swing to it: it stays in
    # front and points the forearm as near as it can from there (measured: the pan
    # ranges 59.7 degrees over the rise and the wave, the forearm within 42.5 degrees).
    path, waving = waving_arm()
    targets = follow(path + waving)
    assert np.degrees(np.abs(np.diff(targets, axis=0))).max() <= MAX_STEP_DEG + 1e-9
    assert np.degrees(np.ptp(targets[:, 0])) < 90.0
    fore_errors = [degrees_between(robot_arm_directions(SPEC, q)[1],
                                   pose.in_arm_frame(pose.forearm))
                   for q, pose in zip(targets[len(path):], waving, strict=True)]
    assert max(fore_errors) < 45.0


def test_without_a_jump_cost_a_waving_forearm_is_followed_over_the_top_without_flips():
    path, waving = waving_arm()
    targets = follow(path + waving, DirectionRetargeter(SPEC, jump_cost=0.0))
    assert np.degrees(np.abs(np.diff(targets, axis=0))).max() <= MAX_STEP_DEG + 1e-9
    assert np.degrees(np.ptp(targets[:, 0])) > 170.0  # the pan turned half a turn
    wave_targets = targets[len(path):]
    fore_errors = [degrees_between(robot_arm_directions(SPEC, q)[1],
                                   pose.in_arm_frame(pose.forearm))
                   for q, pose in zip(wave_targets, waving, strict=True)]
    assert max(fore_errors) < 3.0
    # The shoulder holds its solution through the wave (no swing back and forth).
    assert np.degrees(np.ptp(wave_targets[:, :2], axis=0)).max() < 5.0


def test_a_fixed_value_outside_its_range_is_refused():
    with pytest.raises(ValueError, match="wrist_roll must be inside its joint range"):
        DirectionRetargeter(SPEC, wrist_roll=3.0)


def test_a_negative_weight_is_refused():
    with pytest.raises(ValueError, match="forearm_weight, flexion_weight and hanging_power "
                                         "must be >= 0"):
        DirectionRetargeter(SPEC, forearm_weight=-0.1)
    with pytest.raises(ValueError, match="hanging_power must be >= 0"):
        DirectionRetargeter(SPEC, hanging_power=-1.0)
    with pytest.raises(ValueError, match=r"jump_cost, .* must be >= 0"):
        DirectionRetargeter(SPEC, jump_cost=-1.0)
