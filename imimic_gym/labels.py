"""Labels from the pose model for a user's own footage: `imimic label` and the env's
``annotations="pose"``.

The pose model (`estimators.pose.PoseEstimator`, in video mode) reads the person's arm
in every frame; frames where its shoulder, elbow and wrist are all at ``min_confidence``
or more are labelled, the others left unlabelled. These are a model's labels, not hand
labels: good enough to train or score a tracker on a user's camera without labelling by
hand, and a start that CVAT or Label Studio can import for a person to correct.
"""

from __future__ import annotations

import hashlib
import json
import warnings
import zipfile
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from imimic_gym.atomic import atomic_write, write_json
from imimic_gym.clips.annotations import ARM_KEYPOINTS, truth_from_keypoints
from imimic_gym.clips.types import ClipTruth
from imimic_gym.interrupts import CTRL_C, is_ctrl_c
from imimic_gym.kinematics import keypoints_to_angles

# A link shorter than this share of its usual length in the image is seen nearly end-on
# (`end_on`): docs/decisions/pose-truth.md.
END_ON = 0.5

__all__ = ["PoseLabels", "end_on", "human_truth", "label_frames", "label_video", "pose_truth",
           "video_labels", "within_ranges"]


@dataclass(frozen=True)
class PoseLabels:
    """The pose model's arm in each of T frames.

    Attributes:
        keypoints: (T, 3, 2) float32 input pixels (x, y) of shoulder, elbow, wrist; NaN
            in frames left unlabelled.
        confidence: (T, 3) float32 in [0, 1]; 0 in frames left unlabelled.
        labelled: (T,) bool, the frames whose three keypoints all reach the floor.
        side: (T,) the arm read ("left", "right" or "" for none), the person's own.
    """

    keypoints: np.ndarray
    confidence: np.ndarray
    labelled: np.ndarray
    side: tuple[str, ...]


def _readings(frames: Iterable[np.ndarray], fps: float, arm: str,
              min_confidence: float) -> Iterator[tuple[np.ndarray, Any]]:
    """Each of ``frames`` with the pose model's `ArmReading` of it (None: no reading)."""
    from imimic_gym.estimators.pose.planar import PoseEstimator

    # The estimator's own floor: the same arm is chosen as `imimic mimic` would choose,
    # and a frame below the floor is no reading (unlabelled).
    estimator = PoseEstimator(n_links=1, fps=fps, arm=arm, min_confidence=min_confidence)
    estimator.reset()
    for i, frame in enumerate(frames):
        yield frame, estimator.read(frame, time_s=i / fps)


def _labels(readings: Sequence[Any], min_confidence: float) -> PoseLabels:
    """`PoseLabels` of a list of `ArmReading` or None, one a frame."""
    if not readings:
        raise ValueError("no frames to label")
    keypoints = [np.full((3, 2), np.nan) if r is None else r.keypoints for r in readings]
    confidence = np.asarray([np.zeros(3) if r is None else r.confidence for r in readings],
                            dtype=np.float32)
    labelled = confidence.min(axis=1) >= min_confidence
    points = np.asarray(keypoints, dtype=np.float32)
    points[~labelled] = np.nan
    return PoseLabels(points, confidence, labelled,
                      tuple("" if r is None else r.side for r in readings))


def label_frames(frames: Iterable[np.ndarray], fps: float, arm: str = "auto",
                 min_confidence: float = 0.5,
                 on_frame: Any = None) -> PoseLabels:
    """`PoseLabels` of (H, W, 3) uint8 RGB ``frames``, read in order. ``on_frame(i,
    frame)`` is called on each (to write it out, or show progress)."""
    readings = []
    for i, (frame, reading) in enumerate(_readings(frames, fps, arm, min_confidence)):
        if on_frame is not None:
            on_frame(i, frame)
        readings.append(reading)
    return _labels(readings, min_confidence)


def within_ranges(angles: np.ndarray, labelled: np.ndarray,
                  joint_ranges: Sequence[tuple[float, float]]) -> np.ndarray:
    """``angles`` (T, n) rad with each labelled frame's (``labelled`` (T,) bool) kept
    within its joint's range (low, high) rad, continuing the labelled frame before, as
    the pose estimator keeps its readings (`estimators.pose.continue_within`: a 2-D fold
    seen past 180 degrees stays at its limit). Unlabelled frames are returned as given."""
    from imimic_gym.estimators.pose.planar import continue_within

    kept = np.array(angles, dtype=np.float64)
    previous: list[float | None] = [None] * kept.shape[1]
    for i in np.flatnonzero(labelled):
        for j, joint_range in enumerate(joint_ranges):
            previous[j] = kept[i, j] = continue_within(float(kept[i, j]), joint_range,
                                                       previous[j])
    return kept


def human_truth(keypoints: np.ndarray, labelled: np.ndarray, fps: float, n_links: int,
                reference_direction: float, source: str) -> ClipTruth:
    """The `ClipTruth` of a person's arm from its shoulder, elbow and wrist (T, 3, 2)
    pixels, labelled (T, 3): `clips.annotations.truth_from_keypoints` with the angles
    kept within a human arm's ranges (`estimators.pose.human_joint_ranges`,
    `within_ranges`), so that a robot with those ranges can reach every one."""
    from imimic_gym.estimators.pose.planar import human_joint_ranges

    complete = np.asarray(labelled.all(axis=1), dtype=bool)
    angles = keypoints_to_angles(np.nan_to_num(keypoints), n_links, reference_direction)
    angles = within_ranges(angles, complete, human_joint_ranges(n_links))
    return truth_from_keypoints(keypoints, labelled, fps, n_links, reference_direction,
                                source=source, angles=angles)


def end_on(keypoints: np.ndarray, labelled: np.ndarray,
           shortest: float = END_ON) -> np.ndarray:
    """(T,) bool: the labelled frames (``labelled`` (T,) bool) whose upper arm or forearm
    (shoulder, elbow, wrist ``keypoints`` (T, 3, 2) pixels) looks shorter than
    ``shortest`` times its median over the labelled frames: a link seen nearly end-on,
    whose direction in the image says little about the joint (its 2-D angle swings
    through any value as it turns past the camera's line of sight)."""
    seen = np.zeros(len(keypoints), dtype=bool)
    if not labelled.any():
        return seen
    lengths = np.linalg.norm(np.diff(keypoints, axis=1), axis=2)  # (T, 2): upper, fore
    typical = np.median(lengths[labelled], axis=0)
    short = (lengths < shortest * typical).any(axis=1)
    seen[labelled] = short[labelled]
    return seen


def pose_truth(source: str | Path, frames: np.ndarray, fps: float, n_links: int,
               reference_direction: float, arm: str = "auto") -> ClipTruth:
    """The pose model's arm in ``frames`` (T, H, W, 3) uint8 RGB of the file ``source``
    as truth (`human_truth`; labels from `video_labels`, cached): one arm for the whole
    video (``arm``, or for "auto" the side it read most often, read again on every
    frame when it switched), on the frames where it read that arm with no link seen
    end-on (`end_on`); the others count as unlabelled."""
    labels = video_labels(source, frames, fps, arm=arm)
    sides = np.array(labels.side)
    read = sides[labels.labelled & (sides != "")]
    if arm == "auto" and len(set(read.tolist())) > 1:
        names, counts = np.unique(read, return_counts=True)
        labels = video_labels(source, frames, fps, arm=str(names[np.argmax(counts)]))
    labelled = labels.labelled & ~end_on(labels.keypoints, labels.labelled, END_ON)
    keypoints = labels.keypoints.copy()
    keypoints[~labelled] = np.nan
    return human_truth(keypoints, np.repeat(labelled[:, None], 3, axis=1), fps, n_links,
                       reference_direction, source=f"the pose model on {source}")


# Of the cached labels' layout and of how they are made: bump it when a change to the
# pose estimator (estimators/pose/planar.py, estimators/pose/model.py) changes its readings.
LABELS_VERSION = 1


def _cached_labels_path(source: str | Path, n_frames: int, fps: float, arm: str,
                        min_confidence: float) -> Path | None:
    """Where `video_labels` keeps a file's labels (in `clips.cache.pose_labels_dir`,
    which ``imimic cache --clear`` empties too): named by a hash of the file (path,
    size, modification time), the frames read, the settings and the pose model's version.
    None for a source that is no single file (an image pattern)."""
    from imimic_gym.clips.cache import pose_labels_dir
    from imimic_gym.estimators.pose.model import MEDIAPIPE_VERSION

    path = Path(source)
    if not path.is_file():
        return None
    stat = path.stat()
    key = json.dumps([str(path.resolve()), stat.st_size, stat.st_mtime_ns, n_frames, fps, arm,
                      min_confidence, MEDIAPIPE_VERSION, LABELS_VERSION])
    return pose_labels_dir() / f"{hashlib.sha256(key.encode()).hexdigest()[:32]}.npz"


def video_labels(source: str | Path, frames: np.ndarray, fps: float, arm: str = "auto",
                 min_confidence: float = 0.5, progress: bool = True) -> PoseLabels:
    """`label_frames` of ``frames`` (T, H, W, 3) uint8 RGB, all the frames read from the
    file ``source``, kept in the clip cache (`clips.cache.cache_dir`), so that the env
    made again on the same file (a copy, an unpickled env, each worker of a vector env)
    reads them rather than running the pose model over the video again. A cached file
    that cannot be read is labelled anew; one that cannot be written is warned of. A file
    replaced by another of the same size and modification time (``cp -p``) would read
    the old labels: ``imimic cache --clear`` forgets them. ``progress``: a progress bar
    while labelling."""
    from tqdm.auto import tqdm

    cached = _cached_labels_path(source, len(frames), fps, arm, min_confidence)
    if cached is not None and cached.exists():
        try:
            with np.load(cached, allow_pickle=False) as z:
                labels = PoseLabels(z["keypoints"], z["confidence"], z["labelled"],
                                    tuple(str(side) for side in z["side"]))
            if len(labels.labelled) == len(frames):
                return labels
        except (OSError, ValueError, KeyError, zipfile.BadZipFile):
            pass  # damaged or foreign: label anew
    with tqdm(total=len(frames), unit="frame", desc=f"pose labels {Path(source).name}",
              disable=not progress) as bar:
        labels = label_frames(frames, fps, arm=arm, min_confidence=min_confidence,
                              on_frame=lambda i, frame: bar.update(1))
    if cached is not None:
        try:
            _write_labels(cached, labels)
        except OSError as error:  # the cache only saves time: the labels are still good
            warnings.warn(f"pose labels of {source} not cached in {cached.parent}: {error}",
                          RuntimeWarning, stacklevel=2)
    return labels


def _write_labels(path: Path, labels: PoseLabels) -> None:
    """``labels`` into ``path`` through a temporary file, so readers never see half a file
    (vector-env workers may write the same labels at once)."""
    with atomic_write(path) as f:
        np.savez(f, keypoints=labels.keypoints, confidence=labels.confidence,
                 labelled=labels.labelled, side=np.array(labels.side, dtype=str))


def label_video(source: str | Path, out: str | Path, arm: str = "auto",
                min_confidence: float = 0.5, progress: bool = True,
                fps: float | None = None) -> dict[str, Any]:
    """Write ``out/images/frame_<i>.jpg`` for every frame of ``source`` and
    ``out/labels.json``: COCO keypoints with one ``arm`` category (shoulder, elbow,
    wrist; CVAT's and Label Studio's COCO-keypoints import), one image per frame with its
    ``frame_index``, and an annotation on each frame the pose model labelled (v = 2).
    `clips.annotations.read_annotations` and ``training/train_cnn.py --annotations
    out/labels.json --images out/images`` read it; so does
    ``ImitateVideo-v0(clip=source, annotations=out/labels.json)``. ``fps``: the frame
    rate of a source that reports none (an image sequence).

    The source is opened before anything is written (`VideoOpenError`,
    `VideoFormatError`). Ctrl-C stops early and still writes the labels of the frames
    read so far. Returns a summary: frames, labelled, fps, the paths, ``ended`` (why the
    labelling stopped) and ``reported_frames`` (the container's count, or None)."""
    from tqdm.auto import tqdm

    from imimic_gym.clips.video import VideoReader

    out = Path(out)
    reader = VideoReader(source, fps=fps).open()
    rate, reported = float(reader.fps), reader.frame_count
    images: list[dict[str, Any]] = []
    readings: list[Any] = []
    ended = "end of footage"
    try:
        (out / "images").mkdir(parents=True, exist_ok=True)
        with tqdm(total=reported, unit="frame", desc=f"label {Path(str(source)).name}",
                  disable=not progress) as bar:
            for i, (frame, reading) in enumerate(
                    _readings(reader, rate, arm, min_confidence)):
                name = f"frame_{i:06d}.jpg"
                if not cv2.imwrite(str(out / "images" / name),
                                   cv2.cvtColor(frame, cv2.COLOR_RGB2BGR),
                                   [cv2.IMWRITE_JPEG_QUALITY, 95]):
                    raise OSError(f"cannot write {out / 'images' / name}")
                images.append({"id": i + 1, "file_name": name, "width": int(frame.shape[1]),
                               "height": int(frame.shape[0]), "frame_index": i})
                readings.append(reading)
                bar.update(1)
            bar.total = bar.n  # the end of the footage: the bar ends at the frames it held
            bar.refresh()
    except CTRL_C as error:
        if not (readings and is_ctrl_c(error)):
            raise
        ended = "stopped by Ctrl-C"
        del images[len(readings):]  # an image whose reading Ctrl-C cut off
    finally:
        reader.close()
    labels = _labels(readings, min_confidence)
    skipped = reader.skipped_frames
    if ended == "end of footage" and reader.ended_early():
        ended = (f"footage ended early: {len(readings)} of the {reported} frames its "
                 f"container reports{f' ({skipped} more failed to decode)' if skipped else ''}"
                 f" (a truncated or damaged file?)")
    annotations: list[dict[str, Any]] = []
    for k in np.flatnonzero(labels.labelled):
        points = labels.keypoints[k].astype(np.float64)
        x0, y0 = points.min(axis=0)
        x1, y1 = points.max(axis=0)
        annotations.append({
            "id": len(annotations) + 1, "image_id": int(k) + 1, "category_id": 1,
            "keypoints": [v for (x, y) in points.round(3).tolist() for v in (x, y, 2)],
            "num_keypoints": 3, "iscrowd": 0,
            "bbox": [round(float(x0), 3), round(float(y0), 3), round(float(x1 - x0), 3),
                     round(float(y1 - y0), 3)],
            "area": round(float((x1 - x0) * (y1 - y0)), 3),
            "attributes": {"side": labels.side[k],
                           "confidence": labels.confidence[k].round(3).tolist()},
        })
    data = {
        "info": {"description": f"pose-model labels of {source} (imimic label): a model's "
                                "labels, to be checked"},
        "images": images,
        "annotations": annotations,
        "categories": [{"id": 1, "name": "arm", "supercategory": "person",
                        "keypoints": list(ARM_KEYPOINTS), "skeleton": [[1, 2], [2, 3]]}],
    }
    write_json(out / "labels.json", data, indent=1)
    return {"frames": len(images), "labelled": len(annotations), "fps": rate,
            "labels": str(out / "labels.json"), "images": str(out / "images"),
            "ended": ended, "reported_frames": reported}
