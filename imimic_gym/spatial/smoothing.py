"""A One Euro filter (Casiez, Roussel and Vogel, CHI 2012) over arrays of 3-D points: a
low-pass filter whose cutoff rises with the speed, so a still arm's jitter is smoothed
and a moving arm is followed with little lag.

Each point (a row of the array) gets its own cutoff from its own speed (the norm of its
filtered velocity), so a fast wrist does not unsmooth a still shoulder. Why these
settings: `docs/decisions/pose3d-lift.md`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["OneEuroFilter", "OneEuroSettings"]


@dataclass(frozen=True)
class OneEuroSettings:
    """A One Euro filter's settings.

    Attributes:
        min_cutoff: Hz, the cutoff of a point at rest (lower: smoother, more lag).
        beta: Hz per (m/s), how fast the cutoff rises with the point's speed.
        derivative_cutoff: Hz, the cutoff of the speed estimate itself.
    """

    min_cutoff: float = 1.5
    beta: float = 4.0
    derivative_cutoff: float = 1.0

    def __post_init__(self) -> None:
        for name in ("min_cutoff", "derivative_cutoff"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"OneEuroSettings.{name} must be a positive number of Hz, "
                                 f"got {value!r}")
        if not (math.isfinite(self.beta) and self.beta >= 0):
            raise ValueError(f"OneEuroSettings.beta must be at least 0, got {self.beta!r}")


def _smoothing(cutoff: np.ndarray | float, dt: float) -> np.ndarray:
    """The exponential smoothing factor of a first-order low-pass at ``cutoff`` Hz."""
    tau = 1.0 / (2.0 * math.pi * np.asarray(cutoff, dtype=np.float64))
    return 1.0 / (1.0 + tau / dt)


class OneEuroFilter:
    """One Euro filter over (N, D) arrays (N points of D coordinates, metres), one cutoff
    per point. ``filter(values, dt)`` takes the next sample, ``dt`` seconds after the last
    one, and returns the filtered (N, D) float64 array; the first sample passes as is."""

    def __init__(self, settings: OneEuroSettings | None = None) -> None:
        self.settings = settings if settings is not None else OneEuroSettings()
        self.reset()

    def reset(self) -> None:
        self.value: np.ndarray | None = None
        self.velocity: np.ndarray | None = None

    def filter(self, values: np.ndarray, dt: float) -> np.ndarray:
        values = np.asarray(values, dtype=np.float64)
        if self.value is None or self.velocity is None or self.value.shape != values.shape:
            self.value, self.velocity = values.copy(), np.zeros_like(values)
            return values.copy()
        if not (math.isfinite(dt) and dt > 0):
            raise ValueError(f"OneEuroFilter: dt must be a positive number of seconds, "
                             f"got {dt!r}")
        s = self.settings
        raw_velocity = (values - self.value) / dt
        self.velocity = self.velocity + _smoothing(s.derivative_cutoff, dt) * (
            raw_velocity - self.velocity)
        speed = np.linalg.norm(self.velocity, axis=-1, keepdims=True)
        alpha = _smoothing(s.min_cutoff + s.beta * speed, dt)
        self.value = self.value + alpha * (values - self.value)
        return self.value.copy()
