import math

import cv2
import gymnasium as gym
import mujoco
import numpy as np
import pytest

from imimic_gym.clips.cache import load_clip
from imimic_gym.clips.scenarios import get_scenario
from imimic_gym.estimators.don.chain_fit import blob_ends, facing_point, segment_score
from imimic_gym.estimators.don.config import LinkedDONConfig
from imimic_gym.estimators.don.linked import LinkedDON
from imimic_gym.kinematics import wrap_angle

FPS = 30.0
PIVOT = (100.0, 170.0)
LENGTHS = (60.0, 50.0)
RANGES = ((0.0, 1.6), (0.0, 1.6))

FACING = LinkedDONConfig().facing


def test_segment_score_is_the_tent_of_each_points_distance_to_its_nearest_segment() -> None:
    """Against the distance to a segment worked out point by point: the projection onto
    the segment's line, clamped to its ends (a zero-length segment is its point)."""
    rng = np.random.default_rng(0)
    points = rng.uniform(0, 40, (50, 2))
    starts = rng.uniform(0, 40, (4, 3, 2))
    ends = rng.uniform(0, 40, (4, 3, 2))
    ends[1, 2] = starts[1, 2]
    band = 9.0
    expected = np.zeros(4)
    for k in range(4):
        for p in points:
            nearest = math.inf
            for a, b in zip(starts[k], ends[k], strict=True):
                span = b - a
                t = 0.0 if not span.any() else np.clip((p - a) @ span / (span @ span), 0, 1)
                nearest = min(nearest, math.dist(p, a + t * span))
            expected[k] += max(0.0, 1.0 - nearest / band)
    assert segment_score(points, starts, ends, band) == pytest.approx(expected, abs=1e-9)
    assert expected.min() > 1.0  # every candidate explains some points


def two_bars(q: np.ndarray) -> np.ndarray:
    """(240, 320, 3) uint8: a dark two-link arm (joint angles q (2,) rad, reference
    direction 0 = image right) on a pale wall, drawn with cv2.line."""
    frame = np.full((240, 320, 3), 230, np.uint8)
    start = np.array(PIVOT)
    direction = 0.0
    for angle, length in zip(q, LENGTHS, strict=True):
        direction += angle
        end = start + length * np.array([math.cos(direction), -math.sin(direction)])
        cv2.line(frame, tuple(round(v) for v in start), tuple(round(v) for v in end),
                 (40, 60, 90), 8, cv2.LINE_AA)
        start = end
    return frame


def sweep(n: int = 40) -> np.ndarray:
    """(n, 2) rad: the shoulder turns up at 0.6 rad/s while the elbow closes at 0.45 rad/s."""
    t = np.arange(n)
    return np.stack([0.3 + 0.02 * t, 1.3 - 0.015 * t], axis=1)


def test_two_bars_give_both_angles_and_rates() -> None:
    q = sweep()
    don = LinkedDON((-1, 0), RANGES, fps=FPS, pivot=PIVOT, appearance=False)
    estimates = don.run(two_bars(angles) for angles in q)
    late = estimates[-10:]
    error = np.degrees(np.abs(wrap_angle(np.array([e.angles for e in late]) - q[-10:])))
    # The forearm's farthest moving pixel lies past its end (half the bar's width plus a
    # frame of motion), so its measured length is long and the elbow reads a few degrees
    # open: measured 3.4 and 6.8 degrees at most (the appearance layer's case, below). The
    # shoulder's bound is about twice that (issue 40), the elbow's left at 1.2x.
    assert np.all(error.max(axis=0) < [7.0, 8.0]), error.max(axis=0)
    omega = np.array([e.omega for e in late]).mean(axis=0)
    # rad/s: signs, magnitudes; measured 0.002 and 0.031 off (issue 40: about 2x)
    assert omega.tolist() == pytest.approx([0.6, -0.45], abs=0.06)
    lengths = don.lengths() * don.scale
    assert lengths.tolist() == pytest.approx(LENGTHS, rel=0.25)


def test_no_reported_angle_passes_a_joints_limits() -> None:
    """The elbow closes past its 0 limit to -0.15 rad while the shoulder turns up: the
    fit, which searches a margin past each range, reads it there, but the estimate
    reports the limit."""
    n = 40
    t = np.arange(n)
    q = np.stack([0.3 + 0.02 * t, np.maximum(1.3 - 0.04 * t, -0.15)], axis=1)
    don = LinkedDON((-1, 0), RANGES, fps=FPS, pivot=PIVOT, appearance=False)
    estimates = don.run(two_bars(angles) for angles in q)
    elbow = np.array([e.angles[1] for e in estimates])
    assert elbow.min() >= 0.0
    assert elbow[-5:].tolist() == pytest.approx([0.0] * 5, abs=1e-12)


def test_appearance_layer_reads_each_links_direction_without_its_length() -> None:
    # The fit's elbow sits where its (too long) forearm length puts it; the links' colour
    # lines give their directions whatever the lengths.
    q = sweep()
    errors = {}
    for appearance in (False, True):
        don = LinkedDON((-1, 0), RANGES, fps=FPS, pivot=PIVOT, appearance=appearance)
        angles = np.array([e.angles for e in don.run(two_bars(a) for a in q)])
        errors[appearance] = np.degrees(np.abs(wrap_angle(angles[20:] - q[20:]))).max(axis=0)
    assert errors[False].max() > 5.0  # measured 3.5 and 7.0 degrees at most
    # measured 0.5 and 1.5 (issue 40: the shoulder's about 2x, the elbow's left at 1.4x)
    assert np.all(errors[True] < [1.1, 2.0]), errors[True]


def test_rendered_two_link_chain_is_followed_per_joint() -> None:
    # The shoulder is given here: found from the video it needs 30 frames of motion.
    spec = get_scenario("chain-2", seed=3, n_frames=60)
    clip = load_clip(spec, progress=False)
    don = LinkedDON(spec.link_parents, spec.joint_ranges, fps=clip.fps,
                    reference_direction=spec.reference_direction,
                    pivot=tuple(clip.truth.keypoints[0, 0]))
    angles = np.array([e.angles for e in don.run(clip.frames)])
    error = np.degrees(wrap_angle(angles[15:] - clip.truth.angles[15:]))
    rmse = np.sqrt(np.mean(error**2, axis=0))
    # Measured 0.5 and 2.3 degrees (2.4 and 4.2 with appearance=False); the shoulder's
    # bound about twice that (issue 40), the elbow's left at 1.5x.
    assert np.all(rmse < [1.0, 3.5]), rmse


@pytest.mark.parametrize("seed", [13, 21])
def test_rendered_chain_with_the_shoulder_found_is_not_locked_wrong(seed: int) -> None:
    # Development clip 13 starts slowly: over its first frames the hand's end of the
    # moving arm recurs more than the shoulder's, and the pivot found there locked the
    # shoulder 100 degrees off for a second (settled RMSE 38.6 and 11.7 degrees before
    # the pivot had to face where the shoulder can point). On clip 21 a recheck on the
    # 44 moving pixels of the arm starting to move flipped the elbow 100 degrees for
    # ten frames (2.9 and 30.5 degrees before rechecks waited for a fuller frame).
    spec = get_scenario("chain-2", seed=seed)
    clip = load_clip(spec, progress=False)
    don = LinkedDON(spec.link_parents, spec.joint_ranges, fps=clip.fps,
                    reference_direction=spec.reference_direction)
    angles = np.array([e.angles for e in don.run(clip.frames)])
    error = np.degrees(wrap_angle(angles[15:] - clip.truth.angles[15:]))
    # Measured 0.9 and 2.3 degrees (clip 13), 0.9 and 1.6 (clip 21) (issue 40: about 2x).
    rmse = np.sqrt(np.mean(error**2, axis=0))
    assert np.all(rmse < [1.9, 4.6]), rmse
    shoulder = clip.truth.keypoints[:, 0].mean(axis=0)
    # input px; measured 5.2 (clip 13) and 6.4 (clip 21)
    assert np.hypot(*(don.pivot() * don.scale - shoulder)) < 9.0


def test_rendered_three_link_chain_keeps_the_colour_the_fit_disagrees_with() -> None:
    # About the found shoulder the fit's upper arm and forearm run 10-15 degrees off for
    # dozens of frames on development chain-3 clip 1. The appearance layers read both
    # right; while they dropped a colour for disagreeing with the fit (as the one-link
    # DON's does), every fifth frame fell back to the fit: settled RMSE 13.3 and 16.2
    # degrees at the shoulder and elbow then, 1.0 and 3.0 now. The wrist (a few pixels
    # of hand, read by the fit alone) is not held to anything here: 20.7 degrees.
    spec = get_scenario("chain-3", seed=1)
    clip = load_clip(spec, progress=False)
    don = LinkedDON(spec.link_parents, spec.joint_ranges, fps=clip.fps,
                    reference_direction=spec.reference_direction)
    angles = np.array([e.angles for e in don.run(clip.frames)])
    error = np.degrees(wrap_angle(angles[15:, :2] - clip.truth.angles[15:, :2]))
    # measured 1.1 and 3.0 degrees (issue 40: about 2x)
    rmse = np.sqrt(np.mean(error**2, axis=0))
    assert np.all(rmse < [2.3, 6.0]), rmse


def test_no_motion_black_frames_and_short_clips_give_finite_estimates() -> None:
    still = [two_bars(np.array([0.5, 0.5]))] * 15
    black = [np.zeros((240, 320, 3), np.uint8)] * 15
    for frames in (still, black, still[:3], [still[0]]):
        don = LinkedDON((-1, 0, 0), (*RANGES, (-0.5, 0.5)), fps=FPS)
        estimates = don.run(frames)
        assert len(estimates) == len(frames)
        for e in estimates:
            assert np.all(np.isfinite(e.as_vector())) and e.trust == 0.0
            # Nothing seen: the middle of each joint's range, at rest, trust 0.
            assert e.angles.tolist() == pytest.approx([0.8, 0.8, 0.0])
            assert e.omega.tolist() == [0.0, 0.0, 0.0]


def test_far_ends_recur_at_the_pivot() -> None:
    points = np.array([[0.0, 0.0], [5.0, 0.0], [0.0, 5.0], [10.0, 10.0]])
    first, second = blob_ends(points)
    assert {tuple(first), tuple(second)} == {(0.0, 0.0), (10.0, 10.0)}


def test_the_pivot_is_the_recurring_end_the_arm_reaches_out_from() -> None:
    # Five frames' (pivot end, tip end) pairs of an arm hanging down from (50, 50): the
    # tip barely moves, so its ends recur more (5 within 3 px) than the pivot's (3).
    pairs = [((50, 50), (50, 80)), ((51, 50), (51, 80)), ((50, 51), (50, 81)),
             ((56, 50), (49, 80)), ((44, 50), (50, 79))]
    ends = np.array(pairs, dtype=np.float64).reshape(-1, 2)
    down = (-math.pi / 2, math.radians(60))  # the root points down, +-60 degrees
    # From the tip the arm reaches up, where the root cannot point; from the pivot, down.
    assert facing_point(ends, 3.0, 9.0, down, FACING).tolist() == pytest.approx([50.333, 50.333],
                                                                        abs=1e-3)
    up = (math.pi / 2, math.radians(60))  # were the root to point up, the tip would do
    assert facing_point(ends, 3.0, 9.0, up, FACING).tolist() == pytest.approx([50.0, 80.0])
    right = (0.0, math.radians(30))  # from neither does the arm reach to the right
    assert facing_point(ends, 3.0, 9.0, right, FACING) is None


def test_a_bad_tree_is_refused_by_name() -> None:
    with pytest.raises(ValueError, match=r"parents must list each link's parent before it"):
        LinkedDON((-1, 2, 0), ((0, 1),) * 3)
    with pytest.raises(ValueError, match=r"joint_ranges must give .* each of the 2 links, got 1"):
        LinkedDON((-1, 0), ((0, 1),))


def test_torque_is_the_robot_models_inverse_dynamics() -> None:
    env = gym.make("ImitateVideo-v0", scenario="chain-2", n_frames=5)
    model = env.unwrapped.model
    don = LinkedDON((-1, 0), RANGES, fps=FPS, robot=model)
    estimate = don.run([two_bars(np.array([0.5, 0.5]))] * 3)[-1]  # at rest: no motion
    data = mujoco.MjData(model)
    data.qpos[:] = estimate.angles
    mujoco.mj_forward(model, data)
    # At rest the torque holds the arm against gravity (the vertical plane's bias force).
    assert estimate.omega.tolist() == [0.0, 0.0] and estimate.alpha.tolist() == [0.0, 0.0]
    assert np.abs(data.qfrc_bias).max() > 0.1
    assert estimate.torque == pytest.approx(data.qfrc_bias, abs=1e-9)
    env.close()


def test_noise_and_flashes_are_not_trusted_and_leave_no_velocity() -> None:
    """Frames that change all over (noise, a flash, a cut) are no link's motion: trust 0
    and the arm held, not the 0.83 that noise used to earn, nor a burst of velocity."""
    from imimic_gym.estimators.don.one_link import DON

    rng = np.random.default_rng(0)
    noise = [rng.integers(0, 256, (240, 320, 3), dtype=np.uint8) for _ in range(30)]
    flashes = [np.full((240, 320, 3), 255 * (i % 2), np.uint8) for i in range(30)]
    for make in (lambda: LinkedDON((-1, 0), ((-2.0, 2.0), (-2.0, 2.0)), fps=30.0),
                 lambda: DON(fps=30.0)):
        for frames in (noise, flashes):
            assert max(e.trust for e in make().run(frames)) == 0.0
    spec = get_scenario("chain-2", seed=3)
    clip = load_clip(spec, progress=False)
    frames = [*clip.frames[:60], *noise[:10], *clip.frames[60:90]]
    estimates = LinkedDON(spec.link_parents, spec.joint_ranges, fps=clip.fps).run(frames)
    assert all(e.trust == 0.0 for e in estimates[60:70])
    held = [e.angles for e in estimates[60:70]]
    assert all(np.array_equal(h, held[0]) for h in held)
    # rad/s; measured 0: no rate across the gap (issue 40: a floor of 0.05)
    assert max(np.abs(e.omega).max() for e in estimates[60:80]) < 0.05
