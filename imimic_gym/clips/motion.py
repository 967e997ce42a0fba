"""Joint-angle trajectories for the demonstrator, with exact velocity and acceleration.

Every profile is sampled on the frame clock and returns angle (rad), angular velocity
(rad/s) and angular acceleration (rad/s^2), each of shape (T, n). Derivatives are
analytic, not finite differences, so they can serve as ground truth for DON's omega and
alpha.

- ``sinusoid``: one sine per joint, random phase, 0.25-0.5 Hz.
- ``spline``: minimum-jerk segments between random waypoints, 0.7-1.6 s each. Minimum
  jerk (Flash & Hogan, 1985) is the classic model of a smooth human reach; it is C2 at
  the waypoints (zero velocity and acceleration there).
- ``fast``: the same construction with 0.15-0.35 s segments and full-range jumps, the
  paper's experiment 1 ("extremely random and fast hand movement").
"""

from __future__ import annotations

from typing import Literal

import numpy as np

__all__ = ["MOTION_PROFILES", "MotionProfile", "sample_motion"]

MotionProfile = Literal["sinusoid", "spline", "fast"]
MOTION_PROFILES: tuple[str, ...] = ("sinusoid", "spline", "fast")


def _sinusoid(
    t: np.ndarray, lo: np.ndarray, hi: np.ndarray, rng: np.random.Generator
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    centre, amplitude = (lo + hi) / 2, (hi - lo) / 2
    freq = rng.uniform(0.25, 0.5, size=lo.shape)
    phase = rng.uniform(0, 2 * np.pi, size=lo.shape)
    w = 2 * np.pi * freq
    arg = np.outer(t, w) + phase
    return (
        centre + amplitude * np.sin(arg),
        amplitude * w * np.cos(arg),
        -amplitude * w**2 * np.sin(arg),
    )


def _minimum_jerk(
    t: np.ndarray,
    lo: np.ndarray,
    hi: np.ndarray,
    rng: np.random.Generator,
    segment_s: tuple[float, float],
    min_step: float,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    n = lo.size
    angle = np.empty((t.size, n))
    velocity = np.empty_like(angle)
    acceleration = np.empty_like(angle)
    for j in range(n):
        span = hi[j] - lo[j]
        start_time, start = 0.0, rng.uniform(lo[j], hi[j])
        times, starts, ends, durations = [], [], [], []
        while start_time <= t[-1]:
            duration = rng.uniform(*segment_s)
            # Re-draw until the step is large enough to be a real movement.
            end = rng.uniform(lo[j], hi[j])
            while abs(end - start) < min_step * span:
                end = rng.uniform(lo[j], hi[j])
            times.append(start_time)
            starts.append(start)
            ends.append(end)
            durations.append(duration)
            start_time, start = start_time + duration, end
        seg = np.searchsorted(np.asarray(times), t, side="right") - 1
        t0, q0 = np.asarray(times)[seg], np.asarray(starts)[seg]
        dq, dur = np.asarray(ends)[seg] - q0, np.asarray(durations)[seg]
        s = (t - t0) / dur
        angle[:, j] = q0 + dq * (10 * s**3 - 15 * s**4 + 6 * s**5)
        velocity[:, j] = dq / dur * (30 * s**2 - 60 * s**3 + 30 * s**4)
        acceleration[:, j] = dq / dur**2 * (60 * s - 180 * s**2 + 120 * s**3)
    return angle, velocity, acceleration


def sample_motion(
    profile: MotionProfile,
    joint_ranges: np.ndarray,
    n_frames: int,
    fps: float,
    rng: np.random.Generator,
    margin: float = 0.08,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Sample ``profile`` at ``n_frames`` frames of ``fps`` Hz inside ``joint_ranges``.

    Args:
        joint_ranges: (n, 2) radians, low and high per joint.
        margin: fraction of each range kept free at both ends, so the robot, whose
            joint limits are the same ranges, can always reach the target.

    Returns:
        angle (T, n) rad, angular velocity (T, n) rad/s, angular acceleration (T, n) rad/s^2.
    """
    ranges = np.asarray(joint_ranges, dtype=np.float64)
    width = ranges[:, 1] - ranges[:, 0]
    lo, hi = ranges[:, 0] + margin * width, ranges[:, 1] - margin * width
    t = np.arange(n_frames) / float(fps)
    if profile == "sinusoid":
        return _sinusoid(t, lo, hi, rng)
    if profile == "spline":
        return _minimum_jerk(t, lo, hi, rng, segment_s=(0.7, 1.6), min_step=0.25)
    if profile == "fast":
        return _minimum_jerk(t, lo, hi, rng, segment_s=(0.15, 0.35), min_step=0.5)
    raise ValueError(f"unknown motion profile {profile!r}; expected one of {MOTION_PROFILES}")
