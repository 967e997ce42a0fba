"""Video files written from (H, W, 3) uint8 RGB frames: H.264 where imageio-ffmpeg is
installed (browsers, Jupyter and GitHub play it), OpenCV's mp4v otherwise."""

from __future__ import annotations

import warnings
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import cv2
import numpy as np

__all__ = ["VideoWriteError", "write_video"]


class VideoWriteError(OSError):
    """A video file could not be written; the message names the path and the reason."""


def write_video(path: str | Path, frames: Iterable[np.ndarray], fps: float) -> Path:
    """Write RGB frames to ``path`` as H.264 (libx264 through imageio-ffmpeg's bundled
    ffmpeg, yuv420p, ``+faststart``: what browsers, Jupyter and GitHub play), or, without
    imageio-ffmpeg, as MPEG-4 part 2 (OpenCV's ``mp4v``, which they do not) with a
    warning. All frames must share one (H, W, 3) uint8 shape; an odd side is padded by
    one pixel (H.264 needs even ones). Returns the path.

    ``frames`` may be a generator: each frame is written as it comes, so a long or live
    run needs no memory for them, and the file is finalised even if the generator raises
    (Ctrl-C included): what was written is kept."""
    path = Path(path)
    writer: _Writer | None = None
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
                writer = _Writer(path, shape[1], shape[0], float(fps))
            elif frame.shape != shape:
                raise ValueError(f"frame {i} for {path} is {frame.shape}, earlier frames {shape}")
            writer.write(frame)
    finally:
        if writer is not None:
            writer.close()
    if writer is None:
        raise ValueError(f"no frames to write to {path}")
    return path


def _imageio_ffmpeg() -> Any:
    """imageio-ffmpeg (an ffmpeg with libx264 inside its wheel), or None."""
    try:
        import imageio_ffmpeg
    except ImportError:
        return None
    return imageio_ffmpeg


class _Writer:
    """One video file being written: H.264 through imageio-ffmpeg, else OpenCV's mp4v."""

    def __init__(self, path: Path, width: int, height: int, fps: float) -> None:
        self.path, self.pad = path, (height % 2, width % 2)
        imageio_ffmpeg = _imageio_ffmpeg()
        if imageio_ffmpeg is None:
            warnings.warn(f"imageio-ffmpeg is not installed: {path} is written with OpenCV's "
                          "mp4v codec, which browsers do not play (pip install imageio-ffmpeg)",
                          UserWarning, stacklevel=3)
            self.codec = "mp4v"
            self.cv = cv2.VideoWriter(str(path), cv2.VideoWriter.fourcc(*"mp4v"), fps,
                                      (width, height))
            if not self.cv.isOpened():
                raise VideoWriteError(f"OpenCV cannot open {path} for writing (mp4v codec)")
            return
        self.codec = "h264"
        size = (width + self.pad[1], height + self.pad[0])
        self.ffmpeg = imageio_ffmpeg.write_frames(
            str(path), size, fps=fps, codec="libx264", quality=None, macro_block_size=2,
            output_params=["-preset", "ultrafast", "-crf", "23", "-movflags", "+faststart"])
        try:
            self.ffmpeg.send(None)  # starts ffmpeg
        except (OSError, RuntimeError) as err:
            raise VideoWriteError(f"ffmpeg cannot write {path}: {err}") from err

    def write(self, frame: np.ndarray) -> None:
        if self.codec == "mp4v":
            self.cv.write(np.ascontiguousarray(frame[..., ::-1]))
            return
        if any(self.pad):
            frame = np.pad(frame, ((0, self.pad[0]), (0, self.pad[1]), (0, 0)), mode="edge")
        try:
            self.ffmpeg.send(np.ascontiguousarray(frame))
        except (OSError, RuntimeError, StopIteration) as err:
            raise VideoWriteError(f"ffmpeg stopped writing {self.path}: {err}") from err

    def close(self) -> None:
        if self.codec == "mp4v":
            self.cv.release()
        else:
            self.ffmpeg.close()
