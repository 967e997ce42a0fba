import numpy as np
import pytest

from imimic_gym.metrics import (
    angle_rmse_deg,
    jerk_rms,
    lag_frames,
    max_error_deg,
    recovery_time_s,
)


def test_rmse_and_max_error_in_degrees() -> None:
    truth = np.zeros((4, 1))
    estimate = np.radians([[1.0], [-1.0], [3.0], [-3.0]])
    assert angle_rmse_deg(estimate, truth) == pytest.approx(np.sqrt(5.0))
    assert max_error_deg(estimate, truth) == pytest.approx(3.0)


@pytest.mark.parametrize("shift", [0, 1, 4, -2])
def test_lag_of_a_shifted_signal_is_the_shift(shift: int) -> None:
    t = np.arange(200) / 30.0
    truth = np.sin(2 * np.pi * 0.4 * t)
    follower = np.sin(2 * np.pi * 0.4 * (t - shift / 30.0))
    assert lag_frames(truth, follower) == shift


def test_lag_of_a_still_signal_is_zero() -> None:
    assert lag_frames(np.ones(50), np.ones(50)) == 0


def test_pcp_counts_a_limb_correct_only_when_both_ends_are_within_half_its_length() -> None:
    from imimic_gym.metrics import pcp

    truth = np.array([[[0, 0], [10, 0], [10, 20]]] * 4, dtype=float)  # upper 10, lower 20
    predicted = truth.copy()
    predicted[1, 1] += [4.9, 0]  # elbow off by 4.9: upper (limit 5) and lower (10) still ok
    predicted[2, 1] += [0, 5.1]  # elbow off by 5.1: upper wrong, lower ok
    predicted[3, 2] += [6, 8]  # wrist off by 10.0: lower exactly at the limit, counted ok
    assert pcp(predicted, truth, (0, 1)) == 0.75
    assert pcp(predicted, truth, (1, 2)) == 1.0
    predicted[3, 2] += [0.1, 0]
    assert pcp(predicted, truth, (1, 2)) == 0.75
    assert pcp(truth[:0], truth[:0], (0, 1)) == 0.0


def test_jerk_of_a_cubic_is_its_third_derivative() -> None:
    fps = 30.0
    t = np.arange(40) / fps
    angles = np.radians(2.0) * t**3  # third derivative: 12 deg/s^3
    assert jerk_rms(angles, fps) == pytest.approx(12.0, rel=1e-6)
    assert jerk_rms(angles[:3], fps) == 0.0


def test_recovery_counts_frames_until_the_error_is_small_again() -> None:
    fps = 10.0
    occlusion = np.array([0, 0.5, 0.5, 0, 0, 0, 0, 0, 0, 0], dtype=float)
    truth = np.zeros(10)
    robot = np.radians([0, 20, 20, 20, 10, 4, 0, 0, 0, 0])  # occlusion ends at frame 3
    assert recovery_time_s(robot, truth, occlusion, fps) == pytest.approx(0.2)
    assert recovery_time_s(robot, truth, np.zeros(10), fps) is None
    never = np.radians([0, 20, 20, 20, 20, 20, 20, 20, 20, 20])
    assert recovery_time_s(never, truth, occlusion, fps) == pytest.approx(0.7)


def test_bootstrap_interval_brackets_the_statistic_and_is_seeded() -> None:
    from imimic_gym.metrics import bootstrap_interval

    values = np.arange(100.0)
    low, high = bootstrap_interval(values)
    assert low < 49.5 < high and 43 < low and high < 56
    assert bootstrap_interval(values) == (low, high)
    low, high = bootstrap_interval(values, np.median, level=0.5)
    assert low < 49.5 < high
    assert np.isnan(bootstrap_interval([])[0])


@pytest.mark.parametrize(("level", "tail", "tolerance"),
                         [(0.95, 25.0, 10.0), (0.9, 50.0, 10.0), (0.5, 250.0, 30.0)])
def test_bootstrap_interval_cuts_the_tails_its_level_leaves(level: float, tail: float,
                                                            tolerance: float) -> None:
    """The statistic "first resampled value" over 0..999 is uniform on them, so the
    interval at ``level`` is about (1000 (1 - level) / 2, 1000 - that). Measured at seed 0,
    2000 resamples: (27, 976) at 95%, (54, 952) at 90%, (257, 762) at 50%; each tolerance
    is about three standard errors of its percentiles (3.5 at the 95% tails, 9.7 at 50%)."""
    from imimic_gym.metrics import bootstrap_interval

    low, high = bootstrap_interval(np.arange(1000.0), lambda resample: resample[0],
                                   level=level)
    assert low == pytest.approx(tail, abs=tolerance)
    assert high == pytest.approx(1000 - tail, abs=tolerance)


def test_with_interval_reports_the_95_percent_interval() -> None:
    from imimic_gym.metrics import with_interval

    summary = with_interval(np.arange(1000.0), lambda resample: resample[0])
    assert summary["low"] == pytest.approx(25, abs=10)
    assert summary["high"] == pytest.approx(975, abs=10)


def test_direction_error_on_known_angles():
    from imimic_gym.metrics import direction_error_deg

    a = np.array([[1.0, 0, 0], [1.0, 0, 0], [0, 1.0, 0], [1.0, 0, 0]])
    b = np.array([[1.0, 0, 0], [0, 0, 2.0], [0, -1.0, 0], [1.0, 1e-9, 0]])
    np.testing.assert_allclose(direction_error_deg(a, b), [0, 90, 180, np.degrees(1e-9)],
                               atol=1e-12)


def test_spatial_metrics_leave_out_and_count_frames_without_reading():
    from imimic_gym.metrics import spatial_metrics

    t = 5
    down = np.tile([0.0, 1.0, 0.0], (t, 1))
    tilted = np.tile([0.0, np.cos(0.1), np.sin(0.1)], (t, 1))  # 0.1 rad off
    flexion = np.full(t, 1.0)
    read = np.array([True, True, True, False, True])
    wrong = tilted.copy()
    wrong[3] = [1.0, 0, 0]  # a held pose, far off, in the frame without a reading
    out = spatial_metrics(down, wrong, flexion + np.array([0.1, -0.1, 0.1, 2.0, -0.1]),
                          down, down, flexion, read)
    assert out["forearm_direction_error_deg"] == pytest.approx(np.degrees(0.1))
    assert out["upper_arm_direction_error_deg"] == 0.0
    assert out["elbow_flexion_rmse_deg"] == pytest.approx(np.degrees(0.1))
    assert (out["frames"], out["frames_without_reading"]) == (5, 1)
    none = spatial_metrics(down, down, flexion, down, down, flexion, np.zeros(t, bool))
    assert none["elbow_flexion_rmse_deg"] is None and none["frames_without_reading"] == 5


def test_lag_leaves_out_frames_without_truth() -> None:
    t = np.arange(120) / 30.0
    truth = np.sin(2 * np.pi * 0.7 * t)
    follower = np.roll(truth, 3)
    gappy = truth.copy()
    gappy[40:55] = np.nan  # frames without a label
    assert lag_frames(truth, follower) == 3
    assert lag_frames(gappy, follower) == 3
    assert lag_frames(np.full(10, np.nan), np.zeros(10)) == 0


def test_spatial_metrics_report_each_errors_95th_percentile() -> None:
    from imimic_gym.metrics import spatial_metrics

    t = 21
    down = np.tile([0.0, 1.0, 0.0], (t, 1))
    turns = np.radians(np.arange(t, dtype=float))  # 0..20 degrees, one a frame
    fore = np.stack([np.zeros(t), np.cos(turns), np.sin(turns)], axis=1)
    upper = np.stack([np.sin(2 * turns), np.cos(2 * turns), np.zeros(t)], axis=1)
    flexion_error = np.radians(np.arange(t, dtype=float) - 10)  # -10..10 degrees
    out = spatial_metrics(upper, fore, 1.0 + flexion_error, down, down, np.ones(t),
                          np.ones(t, bool))
    assert out["forearm_direction_error_deg"] == pytest.approx(10.0)
    assert out["forearm_direction_p95_deg"] == pytest.approx(19.0)
    assert out["upper_arm_direction_error_deg"] == pytest.approx(20.0)
    assert out["upper_arm_direction_p95_deg"] == pytest.approx(38.0)
    assert out["elbow_flexion_rmse_deg"] == pytest.approx(np.sqrt(np.mean(
        (np.arange(t) - 10.0) ** 2)))
    assert out["elbow_flexion_p95_deg"] == pytest.approx(10.0)  # of |error|: 0..10, twice
    assert (out["frames"], out["frames_without_reading"]) == (21, 0)
    none = spatial_metrics(upper, fore, flexion_error, down, down, np.ones(t), np.zeros(t, bool))
    assert {key: value for key, value in none.items() if value is not None} == {
        "frames": 21, "frames_without_reading": 21}


def test_direction_error_refuses_directions_that_are_not_3d_pairs() -> None:
    from imimic_gym.metrics import direction_error_deg

    with pytest.raises(ValueError, match=r"directions must both be \(\.\.\., 3\), got \(2, 2\)"):
        direction_error_deg(np.ones((2, 2)), np.ones((2, 2)))
    with pytest.raises(ValueError, match=r"got \(2, 3\) and \(3, 3\)"):
        direction_error_deg(np.ones((2, 3)), np.ones((3, 3)))
    assert direction_error_deg([0, 0, 3.0], [0, 2.0, 0]) == pytest.approx(90.0)


def test_with_interval_of_no_values_is_empty_and_of_values_is_seeded() -> None:
    from imimic_gym.metrics import bootstrap_interval, with_interval

    assert with_interval([]) == {"value": None, "low": None, "high": None, "n": 0}
    values = np.arange(50.0) ** 2
    summary = with_interval(values, np.median)
    low, high = bootstrap_interval(values, np.median, level=0.95, resamples=2000, seed=0)
    assert summary == {"value": float(np.median(values)), "low": low, "high": high, "n": 50}
    assert bootstrap_interval(values, resamples=2000, seed=1) != bootstrap_interval(values)


def test_the_bootstrap_resamples_with_replacement_the_number_it_is_told() -> None:
    from imimic_gym.metrics import bootstrap_interval

    seen: list[int] = []

    def count(resample: np.ndarray) -> float:
        seen.append(len(resample))
        return float(len(np.unique(resample)))

    low, high = bootstrap_interval(np.arange(30.0), count, resamples=500)
    assert seen == [30] * 500
    # Drawing 30 of 30 with replacement leaves about 30 (1 - 1/e) = 19 distinct values.
    assert 15 <= low < 19 < high <= 23


def test_lag_is_at_most_max_lag_and_the_earliest_of_equal_peaks() -> None:
    t = np.arange(300) / 30.0
    truth = np.sin(2 * np.pi * 0.3 * t)
    late = np.roll(truth, 12)
    assert lag_frames(truth, late) == 12
    assert lag_frames(truth, late, max_lag=5) == 5  # the peak lies past the window
    # A period of 10 frames shifted 3: peaks at 3 and -7 (same correlation): the first.
    period = np.sin(2 * np.pi * np.arange(200) / 10.0)
    assert lag_frames(period, np.roll(period, 3), max_lag=8) == -7
    assert lag_frames(np.array([0.0, 1.0]), np.array([1.0, 0.0])) == 0  # too short
    assert lag_frames(np.array([0.0, 1.0, 0.0]), np.array([1.0, 0.0, 0.0])) == -1
    with pytest.raises(ValueError, match=r"the same shape, got \(5, 1\) and \(4, 1\)"):
        lag_frames(np.zeros(5), np.zeros(4))
    assert lag_frames(truth, np.zeros(300)) == 0  # a still follower


def test_lag_sums_its_correlation_over_joints() -> None:
    t = np.arange(240) / 30.0
    one = np.sin(2 * np.pi * 0.5 * t)
    two = np.sin(2 * np.pi * 0.2 * t + 1.0)
    truth = np.stack([one, two], axis=1)
    follower = np.stack([np.roll(one, 4), np.roll(two, 4)], axis=1)
    assert lag_frames(truth, follower) == 4
    assert lag_frames(truth[:, :, None], follower[:, :, None]) == 4  # (T, n, 1) flattened


def test_pcp_refuses_mismatched_keypoints_and_takes_a_threshold() -> None:
    from imimic_gym.metrics import pcp

    truth = np.array([[[0, 0], [10, 0]]] * 2, dtype=float)
    predicted = truth.copy()
    predicted[1, 1] += [3.0, 0]
    assert pcp(predicted, truth, (0, 1), threshold=0.3) == 1.0
    assert pcp(predicted, truth, (0, 1), threshold=0.29) == 0.5
    with pytest.raises(ValueError, match=r"both be \(N, K, 2\), got \(2, 2, 2\) and \(2, 2\)"):
        pcp(predicted, truth[0], (0, 1))
    with pytest.raises(ValueError, match=r"got \(2, 2\) and \(2, 2\)"):
        pcp(truth[0], truth[0], (0, 1))


def test_recovery_uses_its_threshold_and_the_default_is_5_degrees() -> None:
    from imimic_gym.metrics import OCCLUDED, RECOVERED_DEG

    assert (OCCLUDED, RECOVERED_DEG) == (0.1, 5.0)
    fps = 10.0
    occlusion = np.array([0.0, 0.11, 0.0, 0.0, 0.0, 0.0])
    truth = np.zeros((6, 2))
    robot = np.radians([[0, 0], [9, 0], [9, 1], [4.9, 5.1], [0, 5.0], [0, 0]])
    assert recovery_time_s(robot, truth, occlusion, fps) == pytest.approx(0.2)
    assert recovery_time_s(robot, truth, occlusion, fps, threshold_deg=10.0) == 0.0
    # An occlusion of exactly OCCLUDED does not count; two stretches: their mean.
    assert recovery_time_s(robot, truth, np.array([0, 0.1, 0, 0, 0, 0]), fps) is None
    twice = np.array([0.5, 0.0, 0.5, 0.5, 0.0, 0.0])
    assert recovery_time_s(robot, truth, twice, fps) == pytest.approx((0.3 + 0.0) / 2)


def test_jerk_takes_the_short_way_round_and_needs_four_samples() -> None:
    fps = 10.0
    wrapped = np.array([3.1, -3.13, -3.08, -3.0, -2.9])  # crosses pi: unwrap first
    unwrapped = np.unwrap(wrapped)
    third = np.diff(unwrapped, n=3) * fps ** 3
    assert jerk_rms(wrapped, fps) == pytest.approx(np.degrees(np.sqrt(np.mean(third ** 2))))
    assert jerk_rms(wrapped[:4], fps) > 0 and jerk_rms(wrapped[:3], fps) == 0.0
    assert jerk_rms(np.zeros((10, 2)), fps) == 0.0


def test_rmse_and_max_error_wrap_the_error() -> None:
    truth = np.radians([179.0, -179.0])
    estimate = np.radians([-179.0, 179.0])  # 2 degrees off each, the short way
    assert angle_rmse_deg(estimate, truth) == pytest.approx(2.0)
    assert max_error_deg(estimate, truth) == pytest.approx(2.0)
    assert max_error_deg(np.radians([1.0, -4.0]), np.zeros(2)) == pytest.approx(4.0)


def test_the_bootstrap_is_the_seeded_percentile_interval_of_its_resamples() -> None:
    """The documented recipe by hand: 2000 resamples with replacement drawn by
    default_rng(seed), the statistic of each, the interval's percentiles."""
    from imimic_gym.metrics import bootstrap_interval

    values = np.random.default_rng(9).normal(size=40)
    for level, seed in ((0.95, 0), (0.8, 3)):
        picks = np.random.default_rng(seed).integers(0, 40, size=(2000, 40))
        stats = values[picks].mean(axis=1)
        tail = 100 * (1 - level) / 2
        expected = tuple(np.percentile(stats, [tail, 100 - tail]))
        assert bootstrap_interval(values, level=level, seed=seed) == pytest.approx(
            expected, abs=1e-15)
    assert bootstrap_interval([2.5]) == (2.5, 2.5)  # one value: no spread
    assert bootstrap_interval(np.arange(10.0), np.min)[0] == 0.0  # every value drawn


def test_float32_and_integer_inputs_give_the_float64_figures() -> None:
    """Every metric converts its input to float64 first: float32 or integer input gives
    the float64 figure to the bit."""
    from imimic_gym.metrics import (
        bootstrap_interval,
        direction_error_deg,
        pcp,
        spatial_metrics,
        with_interval,
    )

    rng = np.random.default_rng(11)
    a64, b64 = rng.normal(size=(50, 3)), rng.normal(size=(50, 3))
    a32, b32 = a64.astype(np.float32), b64.astype(np.float32)
    a, b = a32.astype(np.float64), b32.astype(np.float64)
    assert direction_error_deg(a32, b32).tolist() == direction_error_deg(a, b).tolist()
    assert direction_error_deg(a32, b).tolist() == direction_error_deg(a, b32).tolist() == \
        direction_error_deg(a, b).tolist()
    values = rng.normal(size=30).astype(np.float32)
    assert bootstrap_interval(values) == bootstrap_interval(values.astype(np.float64))
    assert with_interval(values) == with_interval(values.astype(np.float64))
    angles = np.cumsum(rng.normal(size=(20, 2)), axis=0).astype(np.float32)
    assert jerk_rms(angles, 30.0) == jerk_rms(angles.astype(np.float64), 30.0)
    flexion = rng.uniform(0, 2, 50).astype(np.float32)
    units = a / np.linalg.norm(a, axis=1, keepdims=True)
    as32 = spatial_metrics(units, units, flexion, units, units, np.ones(50), np.ones(50, bool))
    as64 = spatial_metrics(units, units, flexion.astype(np.float64), units, units,
                           np.ones(50), np.ones(50, bool))
    assert as32 == as64
    true32 = rng.uniform(0, 2, 50).astype(np.float32)
    assert spatial_metrics(units, units, flexion, units, units, true32, np.ones(50, bool)) == \
        spatial_metrics(units, units, flexion.astype(np.float64), units, units,
                        true32.astype(np.float64), np.ones(50, bool))
    # PCP on integer pixels: a wrist 3-4-5 px off a 10 px limb is at exactly half.
    truth = np.array([[[0, 0], [10, 0]]])
    predicted = np.array([[[0, 0], [13, 4]]])
    assert pcp(predicted, truth, (0, 1)) == 1.0
    truth32, predicted32 = truth * np.float32(0.1), predicted * np.float32(0.1)
    assert pcp(predicted32, truth32, (0, 1)) == pcp(predicted32.astype(np.float64),
                                                     truth32.astype(np.float64), (0, 1))


def test_jerk_of_several_joints_is_over_all_of_them() -> None:
    fps = 10.0
    t = np.arange(8) / fps
    angles = np.stack([np.radians(1.0) * t ** 3, np.radians(2.0) * t ** 3], axis=1)
    # Third derivatives 6 and 12 deg/s^3: their RMS.
    assert jerk_rms(angles, fps) == pytest.approx(np.sqrt((36 + 144) / 2), rel=1e-9)


def test_recovery_measures_the_error_from_the_truth_up_to_its_threshold() -> None:
    fps = 10.0
    truth = np.radians([[40.0], [40.0], [40.0], [40.0]])
    robot = np.radians([[40.0], [0.0], [33.0], [40.0]])
    occlusion = np.array([0.5, 0.0, 0.0, 0.0])
    assert recovery_time_s(robot, truth, occlusion, fps) == pytest.approx(0.2)
    edge = float(np.degrees(np.abs(robot[2, 0] - truth[2, 0])))  # 7 degrees, as computed
    assert recovery_time_s(robot, truth, occlusion, fps, threshold_deg=edge) == \
        pytest.approx(0.1)


def test_spatial_metrics_read_any_truthy_flags_and_take_the_95th_percentile() -> None:
    from imimic_gym.metrics import spatial_metrics

    t = 21
    down = np.tile([0.0, 1.0, 0.0], (t, 1))
    flexion_error = np.radians(np.arange(t, dtype=float))  # 0..20 degrees
    read = [1] * 20 + [0]
    out = spatial_metrics(down, down, 1.0 + flexion_error, down, down, np.ones(t), read)
    assert (out["frames"], out["frames_without_reading"]) == (21, 1)
    assert out["elbow_flexion_p95_deg"] == pytest.approx(np.percentile(np.arange(20.0), 95))


def test_lag_centres_each_joint_on_its_own_mean() -> None:
    """Joints far from zero, each by its own offset: the lag is the same as centred."""
    t = np.arange(240) / 30.0
    one = 100.0 + np.sin(2 * np.pi * 0.5 * t)
    two = -100.0 + np.sin(2 * np.pi * 0.2 * t + 1.0)
    truth = np.stack([one, two], axis=1)
    follower = np.stack([np.roll(one, 4) + 3.0, np.roll(two, 4) - 7.0], axis=1)
    assert lag_frames(truth, follower) == 4
    assert lag_frames(truth - [100.0, -100.0], follower) == 4


def test_lag_looks_30_frames_each_way_by_default() -> None:
    t = np.arange(600) / 30.0
    truth = np.sin(2 * np.pi * 0.1 * t)  # a 300-frame period
    assert lag_frames(truth, np.roll(truth, 40)) == 30
    assert lag_frames(truth, np.roll(truth, -40)) == -30


def test_lag_takes_the_first_of_exactly_equal_peaks() -> None:
    alternating = np.tile([1.0, -1.0], 10)  # every even shift fits exactly as well
    assert lag_frames(alternating, alternating, max_lag=4) == -4


def test_lag_normalises_each_shift_by_its_frames_with_truth() -> None:
    """Truth at frames 2 and 3 only: the shift of -3 overlaps one of them, whose one
    product (not halved) beats every other shift's."""
    truth = np.array([np.nan, np.nan, 2.0, 1.0, np.nan])
    follower = np.array([-2.0, -2.0, -2.0, 3.0, -2.0])
    assert lag_frames(truth, follower) == -3
