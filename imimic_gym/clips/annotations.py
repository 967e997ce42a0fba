"""COCO-keypoints annotations of a video: shoulder, elbow and wrist per frame, turned into
truth joint angles (DESIGN.md convention).

The file is standard COCO keypoints: ``images`` (one per frame), ``annotations`` (per
person: ``image_id``, ``keypoints`` as flat x, y, v triples, v = 0 unlabelled, 1 occluded,
2 visible) and ``categories`` whose ``keypoints`` list names them. Names may be COCO's
``left_shoulder``/``right_shoulder``... (``side`` picks the arm) or plain ``shoulder``,
``elbow``, ``wrist``.

Decisions:
- Frame of an image: its ``frame_index`` (or ``frame_id``) field if every image has one,
  else the images' order by ``id``.
- Several people in a frame: the one with the most of the three keypoints labelled.
- ``side="auto"``: the arm with more labelled keypoints over the whole file.
- Angles, with image directions CCW from image right (y up): for one link, q1 is the
  forearm's angle from the upper arm (the elbow; the upper arm is the reference link even
  when it moves); for two, q1 is the upper arm's angle from ``reference_direction`` and
  q2 the elbow. Frames without all three keypoints labelled get angles interpolated
  between labelled frames (held at the ends) and ``visible`` False; velocities and
  accelerations are central differences of the unwrapped angles.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from imimic_gym.clips.types import ClipTruth
from imimic_gym.metrics import wrap_angle

__all__ = ["AnnotationError", "arm_keypoints_from_coco", "truth_from_coco",
           "truth_from_keypoints"]

ARM = ("shoulder", "elbow", "wrist")


class AnnotationError(ValueError):
    """An annotation file is unusable; the message names the file and the problem."""


def _names(data: dict, path: str) -> list[str]:
    categories = data.get("categories") or []
    for category in categories:
        if category.get("keypoints"):
            return [str(n) for n in category["keypoints"]]
    raise AnnotationError(f"{path}: no category lists its keypoint names ('keypoints')")


def arm_keypoints_from_coco(path: str | Path, n_frames: int,
                            side: str = "auto") -> tuple[np.ndarray, np.ndarray]:
    """Shoulder, elbow and wrist per frame from a COCO-keypoints file.

    Returns keypoints (T, 3, 2) float32 pixels (x, y; NaN where unlabelled) and labelled
    (T, 3) bool (v > 0), T = ``n_frames``.
    """
    path = str(path)
    if side not in ("auto", "left", "right"):
        raise ValueError(f"side must be 'auto', 'left' or 'right', got {side!r}")
    try:
        data = json.loads(Path(path).read_text())
    except FileNotFoundError as err:
        raise AnnotationError(f"{path}: no such annotation file") from err
    except json.JSONDecodeError as err:
        raise AnnotationError(f"{path} is not JSON: {err}") from err
    if not isinstance(data, dict) or "images" not in data or "annotations" not in data:
        raise AnnotationError(f"{path} is not COCO keypoints: it needs 'images' and "
                              "'annotations'")
    names = _names(data, path)
    sides = [""] if all(n in names for n in ARM) else ["left_", "right_"]
    columns = {}
    for prefix in sides:
        if all(prefix + n in names for n in ARM):
            columns[prefix] = [names.index(prefix + n) for n in ARM]
    if not columns:
        raise AnnotationError(f"{path}: keypoint names {names} have no shoulder, elbow, wrist")

    images = sorted(data["images"], key=lambda image: image["id"])
    key = next((k for k in ("frame_index", "frame_id") if all(k in i for i in images)), None)
    frame_of = {image["id"]: int(image[key]) if key else i for i, image in enumerate(images)}
    if frame_of and max(frame_of.values()) >= n_frames:
        raise AnnotationError(f"{path} annotates frame {max(frame_of.values())}, but the "
                              f"video has {n_frames} frames")

    per_side = {prefix: (np.full((n_frames, 3, 2), np.nan, np.float32),
                         np.zeros((n_frames, 3), bool)) for prefix in columns}
    best = {prefix: np.full(n_frames, -1) for prefix in columns}
    for annotation in data["annotations"]:
        frame = frame_of.get(annotation.get("image_id"))
        if frame is None:
            continue
        triples = np.asarray(annotation.get("keypoints", []), dtype=np.float64).reshape(-1, 3)
        for prefix, idx in columns.items():
            if max(idx) >= len(triples):
                raise AnnotationError(f"{path}: annotation {annotation.get('id')} has "
                                      f"{len(triples)} keypoints, names list {len(names)}")
            labelled = triples[idx, 2] > 0
            if labelled.sum() > best[prefix][frame]:
                best[prefix][frame] = labelled.sum()
                per_side[prefix][0][frame] = np.where(labelled[:, None], triples[idx, :2], np.nan)
                per_side[prefix][1][frame] = labelled
    if side == "auto":
        chosen = max(columns, key=lambda p: per_side[p][1].sum())
    else:
        chosen = "" if "" in columns else f"{side}_"
    return per_side[chosen]


def truth_from_keypoints(keypoints: np.ndarray, labelled: np.ndarray, fps: float, n_links: int,
                         reference_direction: float, source: str = "annotations") -> ClipTruth:
    """Truth angles from shoulder, elbow, wrist keypoints (T, 3, 2) and labels (T, 3).
    See the module docstring for the convention."""
    if n_links not in (1, 2):
        raise ValueError(f"annotated arms have 1 or 2 links (forearm; upper arm and "
                         f"forearm), got n_links={n_links}")
    complete = labelled.all(axis=1)
    if not complete.any():
        raise AnnotationError(f"{source}: no frame has shoulder, elbow and wrist all labelled")

    def direction(a: np.ndarray, b: np.ndarray) -> np.ndarray:
        d = b - a
        return np.arctan2(-d[:, 1], d[:, 0]).astype(np.float64)  # image y points down

    upper = direction(keypoints[:, 0], keypoints[:, 1])
    fore = direction(keypoints[:, 1], keypoints[:, 2])
    elbow = wrap_angle(fore - upper)
    angles = (elbow[:, None] if n_links == 1
              else np.stack([wrap_angle(upper - reference_direction), elbow], axis=1))
    t = np.arange(len(angles))
    filled = np.empty_like(angles)
    for j in range(n_links):
        known = np.unwrap(angles[complete, j])
        filled[:, j] = np.interp(t, t[complete], known)
    dt = 1.0 / fps
    velocity = np.gradient(filled, dt, axis=0) if len(t) > 1 else np.zeros_like(filled)
    acceleration = np.gradient(velocity, dt, axis=0) if len(t) > 1 else np.zeros_like(filled)
    points = keypoints.copy()
    for k in range(3):
        for c in range(2):
            ok = labelled[:, k]
            points[:, k, c] = (np.interp(t, t[ok], keypoints[ok, k, c]) if ok.any() else 0.0)
    return ClipTruth(
        angles=wrap_angle(filled),
        angular_velocity=velocity,
        angular_acceleration=acceleration,
        keypoints=points.astype(np.float32),
        visible=labelled.copy(),
        occlusion=np.zeros(len(t), dtype=np.float32),
        keypoint_names=ARM,
    )


def truth_from_coco(path: str | Path, n_frames: int, fps: float, n_links: int,
                    reference_direction: float, side: str = "auto") -> ClipTruth:
    """`ClipTruth` of a video with ``n_frames`` frames from its COCO-keypoints file."""
    keypoints, labelled = arm_keypoints_from_coco(path, n_frames, side=side)
    return truth_from_keypoints(keypoints, labelled, fps, n_links, reference_direction,
                                source=str(path))
