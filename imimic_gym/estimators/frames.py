"""DON layer 1's frame preparation, shared by every estimator: validate, downscale to a
working resolution, smooth.

Every layer after this runs on the frame area-averaged down to ``working_height`` rows,
with the paper's Gaussian (15x15 at 240 rows, sigma 2.6) scaled by the same factor
(sigma 1.3, 5x5 at 120 rows): the same smoothing in scene units at a fraction of the
pixels, and a cost almost independent of the input resolution. Colour is kept: skin
against a pale wall differs little in grey but a lot in blue. The baselines smooth so;
DON's default is no Gaussian at all, only the area average (`don/one_link.py` says why).
"""

from __future__ import annotations

import cv2
import numpy as np

__all__ = ["FrameShapeError", "WorkingFrames"]


class FrameShapeError(ValueError):
    """A frame is not (H, W, 3) uint8, or differs in size from the clip's first frame."""


class WorkingFrames:
    """Turns input frames into smoothed working-resolution frames.

    Args:
        working_height: rows of the working resolution (never more than the input's).
        gaussian: the Gaussian kernel size the paper uses at 240 rows (odd), scaled to
            the working rows; 0 for no smoothing.
        name: the estimator's name, for error messages.
    """

    def __init__(self, working_height: int = 120, gaussian: int = 15,
                 name: str = "estimator") -> None:
        if gaussian < 0 or (gaussian and gaussian % 2 == 0):
            raise ValueError(f"gaussian must be an odd kernel size or 0, got {gaussian}")
        self.working_height, self.gaussian, self.name = working_height, gaussian, name
        self.reset()

    def reset(self) -> None:
        self.shape: tuple[int, ...] | None = None
        self.scale = 1.0  # input pixels per working pixel

    def _first(self, shape: tuple[int, ...]) -> None:
        self.shape = shape
        self.scale = shape[0] / min(self.working_height, shape[0])
        self.size = (max(1, round(shape[1] / self.scale)), max(1, round(shape[0] / self.scale)))
        # The paper's kernel at 240 rows has OpenCV's default sigma for that size; scale
        # sigma to the working rows and cut the kernel at +-1.5 sigma (5x5 at 120 rows:
        # OpenCV's fast path, 4x cheaper than 7x7).
        self.sigma = 0.0
        self.kernel = 0
        if self.gaussian > 1:
            paper_sigma = 0.3 * ((self.gaussian - 1) * 0.5 - 1) + 0.8
            self.sigma = paper_sigma * self.size[1] / 240
            self.kernel = 2 * round(1.5 * self.sigma) + 1

    def __call__(self, frame: np.ndarray) -> np.ndarray:
        """(h, w, 3) uint8, smoothed, at the working resolution."""
        if not isinstance(frame, np.ndarray) or frame.dtype != np.uint8 or frame.ndim != 3 \
                or frame.shape[2] != 3 or 0 in frame.shape:
            got = (f"{frame.shape} {frame.dtype}" if isinstance(frame, np.ndarray)
                   else type(frame).__name__)
            raise FrameShapeError(f"{self.name} takes (H, W, 3) uint8 RGB frames, got {got}")
        if self.shape is None:
            self._first(frame.shape)
        elif frame.shape != self.shape:
            raise FrameShapeError(
                f"frame is {frame.shape}, but this clip's frames are {self.shape}; "
                "call reset() before a clip of another size"
            )
        if self.scale != 1.0:
            frame = cv2.resize(frame, self.size, interpolation=cv2.INTER_AREA)
        if self.kernel > 1:
            frame = cv2.GaussianBlur(frame, (self.kernel, self.kernel), self.sigma)
        return frame
