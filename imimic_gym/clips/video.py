"""Video files through OpenCV: frames flow in as (H, W, 3) uint8 RGB arrays."""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path

import cv2
import numpy as np

__all__ = ["VideoWriteError", "write_video"]


class VideoWriteError(OSError):
    """A video file could not be written; the message names the path and the reason."""


def write_video(path: str | Path, frames: Iterable[np.ndarray], fps: float) -> Path:
    """Write RGB frames to ``path`` (mp4 with the ``mp4v`` codec; other suffixes as OpenCV
    maps them). All frames must share one (H, W, 3) uint8 shape. Returns the path."""
    path = Path(path)
    writer = None
    shape = None
    try:
        for i, frame in enumerate(frames):
            if frame.dtype != np.uint8 or frame.ndim != 3 or frame.shape[2] != 3:
                raise ValueError(
                    f"frame {i} for {path} must be (H, W, 3) uint8 RGB, "
                    f"got {frame.shape} {frame.dtype}"
                )
            if writer is None:
                shape = frame.shape
                fourcc = cv2.VideoWriter_fourcc(*"mp4v")
                writer = cv2.VideoWriter(str(path), fourcc, float(fps), (shape[1], shape[0]))
                if not writer.isOpened():
                    raise VideoWriteError(f"OpenCV cannot open {path} for writing (mp4v codec)")
            elif frame.shape != shape:
                raise ValueError(f"frame {i} for {path} is {frame.shape}, earlier frames {shape}")
            writer.write(np.ascontiguousarray(frame[..., ::-1]))
    finally:
        if writer is not None:
            writer.release()
    if writer is None:
        raise ValueError(f"no frames to write to {path}")
    return path
