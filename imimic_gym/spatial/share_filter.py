"""`ShareFilter`: the lift's Bayes filter on an arm bone's signed out-of-plane share, and
the elbow's flexion from two bones' beliefs.

A bone's share is its extent along its far end's ray from the ray's point nearest its
start, over its length, in [-1, 1] (negative: toward the camera); `spatial.lift` turns a
share into a point and a point into the readings. Beliefs are (101,) float64 arrays on
`SHARE_GRID` that sum to 1. How the settings were chosen: `docs/decisions/pose3d-lift.md`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from imimic_gym.spatial.arm_pose import angle_between

__all__ = ["SHARE_FILTER", "SHARE_GRID", "ShareFilter", "expected_flexion", "output_share",
           "predict_belief", "uniform_belief", "weigh_readings"]

# The grid of a bone's signed share on which `ShareFilter` keeps its belief.
SHARE_GRID = np.linspace(-1.0, 1.0, 101)
_IN_PLANE_RATIO = np.sqrt(1.0 - SHARE_GRID ** 2)  # each share's 2-D length / length


@dataclass(frozen=True)
class ShareFilter:
    """`ArmLifter`'s Bayes filter on each arm bone's signed share: the bone's extent along
    its far end's ray from the ray's point nearest its start, over its length, in
    [-1, 1] (negative: toward the camera). Its prior is uniform (a direction uniform on
    the sphere). Each frame it weighs two readings:

    - the in-plane ratio r (the in-plane lower bound over the length), Gaussian about
      sqrt(1 - share^2) with standard deviation ``keypoint_noise``, with an ``outlier``
      share of readings taken to say nothing (a pose model stretches a foreshortened
      limb's keypoints);
    - the model's relative depth of the far end from the ray's nearest point, over the
      length, Gaussian about ``depth_gain`` times the share with standard deviation
      ``depth_noise``.

    Between readings the belief spreads by a Gaussian of ``turn_rate`` (share/s) times
    the time step, and a ``jump`` share of it spreads evenly (a turn the filter missed).
    The bone takes the posterior mean of the share times the sign's certainty,
    ``|P(away) - P(toward)| ** certainty_power``: where toward and away are equally
    likely, the bone lies in the image plane, not at one of them at random, and a belief
    split between the two tilts it only as far as one side outweighs the other (so a
    reading that tips the split does not swing the bone from one tilt to its mirror).

    The elbow's flexion (`ArmPose.flexion`) is not the angle between those bones where
    a bone's expected |share| is ``flexion_over_tilts`` or more: there it is averaged over
    that bone's two tilts (`expected_flexion`). A forearm pointing at the camera whose
    sign is unsure lies near the image plane, but its flexion stays bent.

    All attributes are shares of the bone's length (``turn_rate`` per second), >= 0;
    ``keypoint_noise`` and ``depth_noise`` > 0; ``outlier`` and ``jump`` in [0, 1);
    ``certainty_power`` >= 0 (0: the plain posterior mean); ``flexion_over_tilts`` over 1:
    the flexion is always the bones' angle.
    """

    keypoint_noise: float = 0.06
    outlier: float = 0.05
    depth_gain: float = 1.0
    depth_noise: float = 1.0
    turn_rate: float = 8.0
    jump: float = 0.01
    certainty_power: float = 1.0
    flexion_over_tilts: float = 0.6

    def __post_init__(self) -> None:
        for name in ("keypoint_noise", "depth_noise"):
            if not (math.isfinite(getattr(self, name)) and getattr(self, name) > 0):
                raise ValueError(f"ShareFilter.{name} must be > 0, got {getattr(self, name)!r}")
        for name in ("depth_gain", "turn_rate", "certainty_power", "flexion_over_tilts"):
            if not (math.isfinite(getattr(self, name)) and getattr(self, name) >= 0):
                raise ValueError(f"ShareFilter.{name} must be >= 0, got "
                                 f"{getattr(self, name)!r}")
        for name in ("outlier", "jump"):
            if not 0.0 <= getattr(self, name) < 1.0:
                raise ValueError(f"ShareFilter.{name} must be in [0, 1), got "
                                 f"{getattr(self, name)!r}")


# The lift's Bayes filter on the arm bones' shares (`ArmLifter`).
SHARE_FILTER = ShareFilter()


def uniform_belief() -> np.ndarray:
    """`ShareFilter`'s belief before any reading: uniform on `SHARE_GRID`."""
    return np.full(SHARE_GRID.size, 1.0 / SHARE_GRID.size)


def weigh_readings(belief: np.ndarray, ratio: float, evidence: float | None,
                   settings: ShareFilter) -> np.ndarray:
    """The posterior on `SHARE_GRID` of a bone whose ``belief`` (predicted to this frame)
    meets this frame's readings: ``ratio``, its in-plane lower bound over its length, and
    ``evidence``, the model's depth of its far end from the ray's nearest point over its
    length (None: no depth). Never NaN: a posterior that vanishes is uniform."""
    fit = np.exp(-0.5 * ((ratio - _IN_PLANE_RATIO) / settings.keypoint_noise) ** 2)
    log_like = np.log((1.0 - settings.outlier) * fit + settings.outlier + 1e-300)
    if evidence is not None:
        log_like -= 0.5 * ((evidence - settings.depth_gain * SHARE_GRID)
                           / settings.depth_noise) ** 2
    posterior = belief * np.exp(log_like - log_like.max())
    total = float(posterior.sum())
    return posterior / total if total > 0.0 and math.isfinite(total) else uniform_belief()


def output_share(posterior: np.ndarray, settings: ShareFilter) -> float:
    """A bone's share as `ShareFilter` outputs it: the posterior mean times the sign's
    certainty to ``certainty_power``."""
    share = float(posterior @ SHARE_GRID)
    if settings.certainty_power > 0.0:
        certainty = abs(float(posterior[SHARE_GRID > 0.0].sum())
                        - float(posterior[SHARE_GRID < 0.0].sum()))
        share *= certainty ** settings.certainty_power
    return share


def _tilts(posterior: np.ndarray, settings: ShareFilter) -> tuple[np.ndarray, np.ndarray]:
    """(n,) shares and (n,) weights summing to 1 that the elbow's flexion is averaged
    over for one bone: its two tilts (the posterior's mean on each side of the image
    plane, weighed by that side's probability) where its expected |share| is at least
    ``settings.flexion_over_tilts``, else its output share alone."""
    if float(posterior @ np.abs(SHARE_GRID)) < settings.flexion_over_tilts:
        return np.array([output_share(posterior, settings)]), np.ones(1)
    shares, weights = [], []
    for side in (SHARE_GRID > 0.0, SHARE_GRID < 0.0):
        mass = float(posterior[side].sum())
        if mass > 0.0:
            shares.append(float(posterior[side] @ SHARE_GRID[side]) / mass)
            weights.append(mass)
    if not weights:
        return np.zeros(1), np.ones(1)
    return np.array(shares), np.array(weights) / sum(weights)


def expected_flexion(shoulder: np.ndarray, elbow_ray: np.ndarray, wrist_ray: np.ndarray,
                     lengths: tuple[float, float], beliefs: tuple[np.ndarray, np.ndarray],
                     settings: ShareFilter, min_depth: float = 0.2) -> float:
    """The elbow's flexion (rad, in [0, pi]) from the upper arm's and the forearm's
    beliefs (posteriors on `SHARE_GRID`, taken as independent), averaged over each
    bone's tilts (`_tilts`): the elbow on ``elbow_ray`` at the upper arm's share from
    ``shoulder`` ((3,) metres, camera frame), the wrist on ``wrist_ray`` at the forearm's
    from that elbow (rays (3,) with z = 1; ``lengths`` (upper arm, forearm) metres;
    points no nearer than ``min_depth`` metres).
    Under an upper arm in the image plane a forearm's two tilts bend the elbow alike, so
    a forearm whose sign is unsure keeps its flexion, which laid in the plane (its
    output share) it would not."""
    upper_shares, upper_weights = _tilts(beliefs[0], settings)
    fore_shares, fore_weights = _tilts(beliefs[1], settings)

    def ends(starts: np.ndarray, ray: np.ndarray, length: float, shares: np.ndarray
             ) -> np.ndarray:
        a = float(ray @ ray)
        middle = starts @ ray / a  # (n,) t of the ray's points nearest the starts
        t = middle[:, None] + shares[None, :] * length / math.sqrt(a)
        return np.maximum(t, min_depth)[..., None] * ray  # (n, shares, 3)

    elbows = ends(shoulder[None], elbow_ray, lengths[0], upper_shares)[0]
    wrists = ends(elbows, wrist_ray, lengths[1], fore_shares)
    angles = angle_between((elbows - shoulder)[:, None, :], wrists - elbows[:, None, :])
    return float(np.clip(upper_weights @ angles @ fore_weights, 0.0, math.pi))


def predict_belief(posterior: np.ndarray, settings: ShareFilter, dt: float) -> np.ndarray:
    """``posterior`` (on `SHARE_GRID`) ``dt`` seconds on (`ShareFilter`'s spread)."""
    step = float(SHARE_GRID[1] - SHARE_GRID[0])
    spread = max(settings.turn_rate * max(dt, 0.0), 1e-6) / step  # grid steps
    half = min(int(3 * spread) + 1, (SHARE_GRID.size - 1) // 2)
    kernel = np.exp(-0.5 * (np.arange(-half, half + 1) / spread) ** 2)
    moved = np.convolve(posterior, kernel / kernel.sum(), mode="same")
    total = float(moved.sum())
    moved = moved / total if total > 0.0 and math.isfinite(total) else uniform_belief()
    return (1.0 - settings.jump) * moved + settings.jump / SHARE_GRID.size
