"""Tracking metrics shared by the demo, the benchmarks and the evaluation suite.

All angle inputs are radians, shaped (T,) or (T, n); outputs are in degrees or frames.
The 3-D metrics (`direction_error_deg`, `spatial_metrics`) take unit direction vectors
(T, 3) in one frame (any: the angle between two directions does not depend on it).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from imimic_gym.kinematics import wrap_angle

__all__ = [
    "OCCLUDED", "RECOVERED_DEG", "angle_rmse_deg", "bootstrap_interval", "direction_error_deg",
    "jerk_rms", "lag_frames", "max_error_deg", "pcp", "recovery_time_s", "spatial_metrics",
    "with_interval", "wrap_angle",
]

OCCLUDED = 0.1  # a frame counts as occluded when over 10% of the moving links is hidden
RECOVERED_DEG = 5.0  # tracking has recovered once every joint is back within this (deg)


def angle_rmse_deg(estimate: np.ndarray, truth: np.ndarray) -> float:
    """Root-mean-square wrapped angle error over all frames and joints, in degrees."""
    error = wrap_angle(np.asarray(estimate) - np.asarray(truth))
    return float(np.degrees(np.sqrt(np.mean(error**2))))


def max_error_deg(estimate: np.ndarray, truth: np.ndarray) -> float:
    """Largest absolute wrapped angle error over all frames and joints, in degrees."""
    return float(np.degrees(np.max(np.abs(wrap_angle(np.asarray(estimate) - np.asarray(truth))))))


def lag_frames(truth: np.ndarray, follower: np.ndarray, max_lag: int = 30) -> int:
    """Frames by which ``follower`` trails ``truth``: the peak of their cross-correlation.

    Both signals lose their means; the correlation at each shift k in [-max_lag, max_lag]
    is normalised by the overlap, summed over joints, and the best k returned (positive:
    the follower is late). Frames where ``truth`` is NaN (no truth) are left out of the
    means and of every overlap. A flat signal (no motion) has no defined lag: returns 0.
    """
    a = np.asarray(truth, dtype=np.float64).reshape(len(truth), -1)
    b = np.asarray(follower, dtype=np.float64).reshape(len(follower), -1)
    if a.shape != b.shape:
        raise ValueError(
            f"truth and follower must have the same shape, got {a.shape} and {b.shape}"
        )
    known = np.asarray(np.isfinite(a).all(axis=1), dtype=bool)
    if not known.any():
        return 0
    a = np.where(known[:, None], a - a[known].mean(axis=0), 0.0)
    b = b - b[known].mean(axis=0)
    max_lag = min(max_lag, len(a) - 2)
    if max_lag < 0 or not (np.any(a) and np.any(b)):
        return 0
    best_lag, best = 0, -np.inf
    for k in range(-max_lag, max_lag + 1):
        if k >= 0:
            x, y, pairs = a[: len(a) - k], b[k:], known[: len(a) - k]
        else:
            x, y, pairs = a[-k:], b[: len(b) + k], known[-k:]
        score = float(np.sum(x * y)) / max(int(pairs.sum()), 1)
        if score > best + 1e-12:
            best_lag, best = k, score
    return best_lag


def bootstrap_interval(values: np.ndarray, statistic: Any = np.mean, level: float = 0.95,
                       resamples: int = 2000, seed: int = 0) -> tuple[float, float]:
    """The percentile bootstrap interval (``level``, e.g. 95%) of ``statistic`` over
    ``values`` (N,) resampled with replacement ``resamples`` times, seeded: (low, high).
    NaN for no values."""
    values = np.asarray(values, dtype=np.float64)
    if values.size == 0:
        return (math.nan, math.nan)
    rng = np.random.default_rng(seed)
    picks = rng.integers(0, values.size, size=(resamples, values.size))
    stats = np.array([statistic(values[row]) for row in picks])
    tail = 100 * (1 - level) / 2
    low, high = np.percentile(stats, [tail, 100 - tail])
    return float(low), float(high)


def with_interval(values: Any, statistic: Any = np.mean) -> dict[str, Any]:
    """``statistic`` of ``values`` (N,) with its 95% `bootstrap_interval`, as
    {"value", "low", "high", "n"}; all None (n 0) for no values."""
    values = np.asarray(values, dtype=np.float64)
    if values.size == 0:
        return {"value": None, "low": None, "high": None, "n": 0}
    low, high = bootstrap_interval(values, statistic)
    return {"value": float(statistic(values)), "low": low, "high": high, "n": int(values.size)}


def pcp(predicted: np.ndarray, truth: np.ndarray, limb: tuple[int, int],
        threshold: float = 0.5) -> float:
    """Percentage of correct parts (PCP@threshold) of one limb, as a fraction in [0, 1].

    A limb is correct when both its end points lie within ``threshold`` times the limb's
    true length of their true positions (Ferrari et al.; the paper's PCP 0.5).

    Args:
        predicted, truth: (N, K, 2) keypoints, pixels.
        limb: the indices of the limb's two end points among the K.
    Returns:
        the fraction of the N samples whose limb is correct (0.0 for N = 0).
    """
    predicted, truth = np.asarray(predicted, np.float64), np.asarray(truth, np.float64)
    if predicted.shape != truth.shape or predicted.ndim != 3:
        raise ValueError(f"predicted and truth must both be (N, K, 2), got {predicted.shape} "
                         f"and {truth.shape}")
    if len(truth) == 0:
        return 0.0
    a, b = limb
    length = np.linalg.norm(truth[:, a] - truth[:, b], axis=1)
    error = np.linalg.norm(predicted[:, [a, b]] - truth[:, [a, b]], axis=2)
    return float(np.mean(np.all(error <= threshold * length[:, None], axis=1)))


def jerk_rms(angles: np.ndarray, fps: float) -> float:
    """RMS jerk of a joint trajectory (T,) or (T, n) rad sampled at ``fps``: the third
    finite difference times fps^3, over all joints, in deg/s^3. Fewer than 4 samples: 0.

    A tracker that follows a noisy estimate shakes the robot; this is how much.
    """
    a = np.asarray(angles, dtype=np.float64).reshape(len(angles), -1)
    if len(a) < 4:
        return 0.0
    third = np.diff(np.unwrap(a, axis=0), n=3, axis=0) * float(fps) ** 3
    return float(np.degrees(np.sqrt(np.mean(third**2))))


def recovery_time_s(robot: np.ndarray, truth: np.ndarray, occlusion: np.ndarray, fps: float,
                    threshold_deg: float = RECOVERED_DEG) -> float | None:
    """Mean time (s) from the end of each occluded stretch (occlusion (T,) over `OCCLUDED`)
    until every joint's error is within ``threshold_deg`` again.

    A stretch after which tracking never recovers counts the rest of the clip (the value
    is then a lower bound). None when no occluded stretch ends inside the clip.
    """
    occluded = np.asarray(occlusion) > OCCLUDED
    ends = np.flatnonzero(occluded[:-1] & ~occluded[1:]) + 1
    if len(ends) == 0:
        return None
    error = np.degrees(np.abs(wrap_angle(np.asarray(robot) - np.asarray(truth))))
    within = error.reshape(len(error), -1).max(axis=1) <= threshold_deg
    times = []
    for end in ends:
        back = np.flatnonzero(within[end:])
        times.append((back[0] if len(back) else len(within) - end) / float(fps))
    return float(np.mean(times))


def direction_error_deg(estimate: np.ndarray, truth: np.ndarray) -> np.ndarray:
    """Angle in degrees between direction vectors ``estimate`` and ``truth`` (..., 3),
    per row, in [0, 180] (atan2 of the cross and dot products: exact near 0 and 180)."""
    a, b = np.asarray(estimate, np.float64), np.asarray(truth, np.float64)
    if a.shape != b.shape or a.shape[-1:] != (3,):
        raise ValueError(f"directions must both be (..., 3), got {a.shape} and {b.shape}")
    cross = np.linalg.norm(np.cross(a, b), axis=-1)
    return np.degrees(np.arctan2(cross, np.sum(a * b, axis=-1)))


def spatial_metrics(upper: np.ndarray, forearm: np.ndarray, flexion: np.ndarray,
                    true_upper: np.ndarray, true_forearm: np.ndarray,
                    true_flexion: np.ndarray, read: np.ndarray) -> dict[str, Any]:
    """How well a 3-D estimate follows the arm over a clip of T frames.

    Args:
        upper, forearm: (T, 3) estimated unit directions of the upper arm and forearm.
        flexion: (T,) estimated elbow flexion, rad.
        true_upper, true_forearm, true_flexion: the same from the truth.
        read: (T,) bool, the estimator saw the arm in that frame (trust > 0); frames
            without a reading are left out of the errors and counted.
    Returns:
        ``elbow_flexion_rmse_deg``, ``forearm_direction_error_deg`` and
        ``upper_arm_direction_error_deg`` (medians over the frames read), their 95th
        percentiles (``*_p95_deg``), ``frames``, ``frames_without_reading``; the errors
        None where no frame was read (never NaN).
    """
    read = np.asarray(read, dtype=bool)
    upper_error = direction_error_deg(upper, true_upper)[read]
    fore_error = direction_error_deg(forearm, true_forearm)[read]
    flex_error = np.degrees(np.asarray(flexion, np.float64) - np.asarray(true_flexion))[read]
    any_read = bool(read.any())

    def stat(values: np.ndarray, how: Any) -> float | None:
        return float(how(values)) if any_read else None

    return {
        "elbow_flexion_rmse_deg": stat(flex_error, lambda e: np.sqrt(np.mean(e**2))),
        "elbow_flexion_p95_deg": stat(np.abs(flex_error), lambda e: np.percentile(e, 95)),
        "forearm_direction_error_deg": stat(fore_error, np.median),
        "forearm_direction_p95_deg": stat(fore_error, lambda e: np.percentile(e, 95)),
        "upper_arm_direction_error_deg": stat(upper_error, np.median),
        "upper_arm_direction_p95_deg": stat(upper_error, lambda e: np.percentile(e, 95)),
        "frames": int(read.size),
        "frames_without_reading": int(read.size - read.sum()),
    }
