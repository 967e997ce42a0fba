"""A recorded video read whole into a `Clip` (`load_video`): random access, what an RL
env resets into; bounded by ``$IMIMIC_VIDEO_MAX_GB`` (streaming: `clips.video`)."""

from __future__ import annotations

import math
import os
from collections.abc import Generator, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from imimic_gym.clips.types import Clip, ClipTruth
from imimic_gym.clips.video import (
    DEFAULT_JOINT_RANGE,
    DEFAULT_REFERENCE_DIRECTION,
    VideoFormatError,
    VideoReader,
    video_meta,
)

__all__ = ["DEFAULT_VIDEO_MAX_GB", "load_video", "video_memory_limit"]

DEFAULT_VIDEO_MAX_GB = 8.0  # load_video's bound on the frames it holds in memory


def load_video(
    source: str | Path,
    annotations: str | Path | None = None,
    *,
    n_links: int = 1,
    reference_direction: float = DEFAULT_REFERENCE_DIRECTION,
    joint_ranges: Sequence[tuple[float, float]] | None = None,
    fps: float | None = None,
    max_frames: int | None = None,
    side: str = "auto",
) -> Clip:
    """Read a recorded video into a `Clip`: frames (T, H, W, 3) uint8 RGB, the file's fps.

    Args:
        source: the file (or image pattern, see `VideoReader`).
        annotations: a COCO-keypoints JSON with shoulder, elbow and wrist per frame (see
            `imimic_gym.clips.annotations`); it becomes ``clip.truth``. ``"pose"``: the
            pose model's arm is the truth (pseudo-truth, `imimic_gym.labels.pose_truth`:
            one arm for the whole video; kept in the clip cache, so a second load of the
            same file does not run the model again). Either way a person's arm: its
            angles are kept within a human arm's ranges, frames without a reading are
            filled in and marked (``truth.labelled``). Or the truth JSON that ``imimic
            clip`` writes beside its video (`clips.annotations.write_clip_truth`): the
            clip's own truth and robot geometry. None: no truth.
        n_links: moving links the robot copies (1: the forearm, 2: upper arm and forearm);
            a truth JSON has its own.
        reference_direction: image direction of the fixed reference link, rad CCW from
            image right (default: image down).
        joint_ranges: per link (low, high) rad; default a human arm's
            (`estimators.pose.human_joint_ranges`) for a video annotated with a person's
            arm, else `DEFAULT_JOINT_RANGE` each (the servo's).
        fps: frame rate for sources that report none.
        max_frames: read at most this many frames (memory: T x H x W x 3 bytes).
        side: which arm the annotations describe: "left", "right" or "auto".

    ``meta`` holds ``reference_direction`` and ``joint_ranges`` (so the env builds a
    matching robot), ``skipped_frames`` (corrupt frames left out) and, with truth,
    ``truth_source`` ("annotations", "pose", or "render" for a truth JSON).
    """
    from imimic_gym.clips.annotations import arm_keypoints_from_coco, read_clip_truth

    file_truth: ClipTruth | None = None
    geometry: dict[str, Any] = {}
    if annotations is not None and annotations != "pose" and _is_truth_file(annotations):
        file_truth, geometry = read_clip_truth(annotations)
        n_links = int(geometry.get("n_links", file_truth.n_joints))
        reference_direction = float(geometry.get("reference_direction", reference_direction))
        if joint_ranges is None and "joint_ranges" in geometry:
            joint_ranges = [(float(lo), float(hi)) for lo, hi in geometry["joint_ranges"]]
    elif annotations is not None and joint_ranges is None:
        from imimic_gym.estimators.pose.planar import human_joint_ranges

        joint_ranges = human_joint_ranges(n_links)
    ranges = tuple(joint_ranges) if joint_ranges is not None else (DEFAULT_JOINT_RANGE,) * n_links
    reader = VideoReader(source, fps=fps)
    stream = iter(reader)
    stacked = _read_all(reader, stream, max_frames)
    meta = {**video_meta(reader, n_links, reference_direction, ranges),
            "skipped_frames": reader.skipped_frames}
    truth = None
    if file_truth is not None:
        assert annotations is not None
        truth = _truth_of_frames(file_truth, len(stacked), annotations)
        meta.update({k: v for k, v in geometry.items() if k != "joint_ranges"},
                    annotations=str(annotations), truth_source="render")
    elif annotations == "pose":
        # Pseudo-truth: the pose model's arm on the frames it is sure of (`labels.py`).
        from imimic_gym.labels import pose_truth

        arm = side if side in ("left", "right") else "auto"
        truth = pose_truth(source, stacked, reader.fps, n_links, reference_direction, arm=arm)
        meta.update(annotations="pose", truth_source="pose")
    elif annotations is not None:
        from imimic_gym.labels import human_truth

        keypoints, labelled = arm_keypoints_from_coco(annotations, len(stacked), side=side)
        truth = human_truth(keypoints, labelled, reader.fps, n_links, reference_direction,
                            source=str(annotations))
        meta.update(annotations=str(annotations), truth_source="annotations")
    return Clip(frames=stacked, fps=reader.fps, truth=truth, meta=meta)


def _is_truth_file(annotations: str | Path) -> bool:
    """Whether ``annotations`` is a clip's truth JSON (`imimic clip`) rather than COCO;
    a file that cannot be read is left to the COCO reader to report."""
    import json

    from imimic_gym.clips.annotations import is_clip_truth

    try:
        return is_clip_truth(json.loads(Path(annotations).read_text()))
    except (OSError, ValueError):
        return False


def _truth_of_frames(truth: ClipTruth, n_frames: int, annotations: str | Path) -> ClipTruth:
    """``truth`` of a truth JSON cut to the ``n_frames`` frames read (``max_frames``);
    AnnotationError when it has fewer."""
    from dataclasses import replace

    from imimic_gym.clips.annotations import AnnotationError

    have = len(truth.angles)
    if have < n_frames:
        raise AnnotationError(f"{annotations} has truth for {have} frames, but the video "
                              f"has {n_frames}")
    if have == n_frames:
        return truth
    cut = slice(0, n_frames)
    return replace(truth, angles=truth.angles[cut], angular_velocity=truth.angular_velocity[cut],
                   angular_acceleration=truth.angular_acceleration[cut],
                   keypoints=truth.keypoints[cut], visible=truth.visible[cut],
                   occlusion=truth.occlusion[cut],
                   labelled=None if truth.labelled is None else truth.labelled[cut],
                   **{name: getattr(truth, name)[cut] for name in ("points3d", "points2d",
                                                                  "arm_angles")
                      if getattr(truth, name) is not None})


def video_memory_limit() -> float:
    """Bytes of frames `load_video` may hold, from ``$IMIMIC_VIDEO_MAX_GB`` (GB of 10^9
    bytes, default `DEFAULT_VIDEO_MAX_GB`)."""
    raw = os.environ.get("IMIMIC_VIDEO_MAX_GB", "").strip()
    try:
        gb = float(raw) if raw else DEFAULT_VIDEO_MAX_GB
    except ValueError:
        gb = math.nan
    if not gb > 0:
        raise ValueError(f"IMIMIC_VIDEO_MAX_GB must be a positive number of GB, got {raw!r}")
    return gb * 1e9


def _read_all(reader: VideoReader, stream: Generator[np.ndarray, None, None],
              max_frames: int | None) -> np.ndarray:
    """Every frame of ``stream`` (up to ``max_frames``) in one preallocated (T, H, W, 3)
    array when the container says how many there are (no list and stacked copy: half
    the peak memory), refusing up front a video that would not fit `video_memory_limit`."""
    limit = video_memory_limit()
    first = next(stream, None)
    if first is None:
        raise VideoFormatError(f"{reader.name}: no frame could be decoded")
    count = reader.frame_count or 0
    if max_frames is not None:
        count = min(count, max_frames) if count else max_frames
    need = max(count, 1) * first.nbytes
    if need > limit:
        stream.close()
        raise VideoFormatError(
            f"{reader.name}: {count} frames of {first.shape[1]}x{first.shape[0]} take "
            f"{need / 1e9:.3g} GB in memory, over the {limit / 1e9:g} GB bound "
            "(IMIMIC_VIDEO_MAX_GB); read fewer (max_frames=, n_frames=), or stream it "
            "(clips.video.stream_video, imimic mimic), which holds a few frames at a time")
    frames = np.empty((max(count, 1), *first.shape), dtype=np.uint8)
    frames[0], n = first, 1
    for frame in stream:
        if max_frames is not None and n >= max_frames:
            break
        if n == len(frames):  # the container undercounted: grow by half
            if (n + n // 2 + 1) * first.nbytes > limit:
                stream.close()
                raise VideoFormatError(f"{reader.name}: over {n} frames, more than the "
                                       f"{limit / 1e9:g} GB bound (IMIMIC_VIDEO_MAX_GB) holds")
            frames = np.concatenate([frames, np.empty_like(frames[: n // 2 + 1])])
        frames[n] = frame
        n += 1
    stream.close()  # releases the capture now
    if n < len(frames):  # the container overcounted: give the rest back, in place
        frames.resize((n, *first.shape), refcheck=False)
    return frames
