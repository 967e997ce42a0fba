"""A pinhole camera: the intrinsics that take 3-D points in the camera frame to pixels and


Camera frame (used by everything 3-D here): metres, x right, y down, z away from the
camera along its optical axis. Pixels are (x, y), x right, y down, as OpenCV's:
pixel (u, v) = (fx * x / z + cx, fy * y / z + cy).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["GUESSED_FOV_DEG", "Intrinsics"]

# Degrees across the longer side: the camera assumed for footage whose camera is unknown
# (a phone's main camera, 26 mm equivalent, spans about 69; webcams about 50-70).
GUESSED_FOV_DEG = 60.0


@dataclass(frozen=True)
class Intrinsics:
    """Pinhole intrinsics, pixels. ``fx``, ``fy``: focal lengths; ``cx``, ``cy``: the
    principal point; ``width``, ``height``: the image size the numbers are for."""

    fx: float
    fy: float
    cx: float
    cy: float
    width: int
    height: int

    def __post_init__(self) -> None:
        values = (self.fx, self.fy, self.cx, self.cy)
        if not all(math.isfinite(v) for v in values) or self.fx <= 0 or self.fy <= 0:
            raise ValueError(f"Intrinsics need finite values and positive focal lengths, "
                             f"got fx={self.fx}, fy={self.fy}, cx={self.cx}, cy={self.cy}")
        if self.width < 1 or self.height < 1:
            raise ValueError(f"Intrinsics need a positive image size, got "
                             f"{self.width}x{self.height}")

    @classmethod
    def from_fovy(cls, fovy_deg: float, width: int, height: int) -> Intrinsics:
        """A camera with square pixels, its principal point at the image centre and a
        vertical field of view of ``fovy_deg`` degrees (as MuJoCo's cameras are)."""
        if not 0 < fovy_deg < 180:
            raise ValueError(f"fovy must be in (0, 180) degrees, got {fovy_deg!r}")
        f = 0.5 * height / math.tan(math.radians(fovy_deg) / 2)
        return cls(fx=f, fy=f, cx=width / 2, cy=height / 2, width=width, height=height)

    @classmethod
    def from_fov(cls, fov_deg: float, width: int, height: int) -> Intrinsics:
        """A camera with square pixels, its principal point at the image centre and a
        field of view of ``fov_deg`` degrees across the image's longer side (a landscape
        video's horizontal one, a portrait video's vertical one)."""
        if not (math.isfinite(fov_deg) and 0 < fov_deg < 180):
            raise ValueError(f"the field of view must be in (0, 180) degrees, got "
                             f"{fov_deg!r}")
        f = 0.5 * max(width, height) / math.tan(math.radians(fov_deg) / 2)
        return cls(fx=f, fy=f, cx=width / 2, cy=height / 2, width=width, height=height)

    @classmethod
    def guess(cls, width: int, height: int) -> Intrinsics:
        """A typical webcam or phone (`GUESSED_FOV_DEG` across the longer side), for
        footage whose camera is unknown."""
        return cls.from_fov(GUESSED_FOV_DEG, width, height)

    @property
    def fov_deg(self) -> float:
        """The field of view across the image's longer side, degrees."""
        half, f = ((0.5 * self.width, self.fx) if self.width >= self.height
                   else (0.5 * self.height, self.fy))
        return math.degrees(2 * math.atan(half / f))

    def scaled(self, width: int, height: int) -> Intrinsics:
        """The same camera at another image size."""
        sx, sy = width / self.width, height / self.height
        return Intrinsics(self.fx * sx, self.fy * sy, self.cx * sx, self.cy * sy, width,
                          height)

    def project(self, points: np.ndarray) -> np.ndarray:
        """(..., 3) camera-frame metres (z > 0) to (..., 2) pixels (x, y)."""
        p = np.asarray(points, dtype=np.float64)
        z = p[..., 2]
        return np.stack([self.fx * p[..., 0] / z + self.cx, self.fy * p[..., 1] / z + self.cy],
                        axis=-1)

    def rays(self, pixels: np.ndarray) -> np.ndarray:
        """(..., 2) pixels to (..., 3) rays through them, scaled to z = 1."""
        u = np.asarray(pixels, dtype=np.float64)
        return np.stack([(u[..., 0] - self.cx) / self.fx, (u[..., 1] - self.cy) / self.fy,
                         np.ones(u.shape[:-1])], axis=-1)

    def back_project(self, pixels: np.ndarray, depth: np.ndarray) -> np.ndarray:
        """(..., 2) pixels and (...) depth along the optical axis (z, metres) to (..., 3)
        camera-frame points."""
        return self.rays(pixels) * np.asarray(depth, dtype=np.float64)[..., None]
