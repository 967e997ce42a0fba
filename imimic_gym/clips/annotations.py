"""COCO-keypoints JSON, the one annotation format: read and write labelled arms.

This is what CVAT and Label Studio export. Two kinds of category are read:

- an ``arm`` category whose keypoints are ``shoulder, elbow, wrist`` (what
  `write_annotations` writes, and what a user labelling their own footage should use);
- COCO's ``person`` category (17 keypoints): the arm is shoulder, elbow and wrist of one
  side (indices 5-10). The person's left side is taken when all three are labelled (it is
  the side our rendered demonstrator moves: on the image's right for a person facing the
  camera), else the right side; a person with neither side complete is skipped.

One arm per image: when an image has several usable annotations, the largest (by
``area``, else by the keypoints' extent) is kept, since the estimators follow one arm.

Keypoints are (x, y) pixels, x = column, y = row. COCO's visibility flag v is 0 (not
labelled), 1 (labelled, occluded) or 2 (labelled, visible); ``labelled`` is v > 0.
Images written by `clips.dataset` carry an ``imimic_render`` record (the `ClipSpec`
fields and the frame index) from which their pixels are regenerated.

Videos. A COCO file can also annotate the frames of a video (one image per frame): its
``frame_index`` (or ``frame_id``) field if every image has one, else the images' order by
``id``. `truth_from_coco` turns it into a `ClipTruth`:
- several people in a frame: the one with the most of the three keypoints labelled;
- ``side="auto"``: the arm with more labelled keypoints over the whole file (one side for
  the whole video, not per frame);
- frames without all three keypoints labelled get angles interpolated between labelled
  frames (held at the ends) and ``visible`` False; velocities and accelerations are
  central differences of the unwrapped angles.

Angles follow one convention (`imimic_gym.robots.planar`), `kinematics.keypoints_to_angles`: for
one link, q1 is the forearm's angle from the upper arm (the upper arm is the reference
link even when it moves); for two, q1 is the upper arm's angle from
``reference_direction`` and q2 the elbow. Image directions are CCW from image right, with
y up.
"""

from __future__ import annotations

import json
import math
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from imimic_gym.atomic import write_json
from imimic_gym.clips.types import ClipTruth
from imimic_gym.kinematics import keypoints_to_angles, wrap_angle

__all__ = [
    "ARM_KEYPOINTS",
    "AnnotationError",
    "ArmAnnotation",
    "arm_keypoints_from_coco",
    "image_path",
    "is_clip_truth",
    "keypoints_to_angles",
    "read_annotations",
    "read_clip_truth",
    "truth_from_coco",
    "truth_from_keypoints",
    "write_annotations",
    "write_clip_truth",
]

ARM_KEYPOINTS = ("shoulder", "elbow", "wrist")
COCO_SIDES = {"left": (5, 7, 9), "right": (6, 8, 10)}  # shoulder, elbow, wrist indices


class AnnotationError(ValueError):
    """A COCO-keypoints file is malformed; the message names the file and the entry."""


@dataclass(frozen=True)
class ArmAnnotation:
    """One labelled arm in one image.

    Attributes:
        file_name: the image's file name as the JSON gives it (relative to the images
            folder).
        width, height: the image's size in pixels.
        keypoints: (3, 2) float32 pixel coordinates of shoulder, elbow, wrist.
        labelled: (3,) bool, the keypoint has a position (COCO v > 0).
        image_id: the COCO image id.
        render: for rendered images, the record that regenerates them (`clips.dataset`);
            None for photos.
        side: "left" or "right", the person's own, for COCO ``person`` annotations; None
            for an ``arm`` category.
    """

    file_name: str
    width: int
    height: int
    keypoints: np.ndarray
    labelled: np.ndarray
    image_id: int
    render: dict[str, Any] | None = field(default=None, compare=False)
    side: str | None = field(default=None, compare=False)


def _need(entry: dict, key: str, where: str, path: Path) -> Any:
    if not isinstance(entry, dict) or key not in entry:
        raise AnnotationError(f"{path}: {where} has no {key!r} key")
    return entry[key]


def _numbers(values: Any, where: str, path: Path) -> np.ndarray:
    """A COCO keypoint list (x, y, v, ...) as float64: every entry a finite number. A
    null or a string is an error naming the file and the annotation (a null coordinate
    once became NaN and ruined a whole training run)."""
    if not isinstance(values, list) or len(values) % 3:
        got = f"{len(values)} values" if isinstance(values, list) else type(values).__name__
        raise AnnotationError(f"{path}: {where} 'keypoints' must be a list of x, y, v "
                              f"triples, got {got}")
    for k, value in enumerate(values):
        if isinstance(value, bool) or not isinstance(value, (int, float)) \
                or not math.isfinite(value):
            raise AnnotationError(
                f"{path}: {where} keypoint {k // 3} has {'xyv'[k % 3]} = {value!r}; "
                "expected a finite number (COCO marks an unlabelled keypoint 0, 0, 0)")
    return np.asarray(values, dtype=np.float64)


def _indices(names: list[str], keypoints: Iterable[str]) -> tuple[int, int, int]:
    """Where the (shoulder, elbow, wrist) ``keypoints`` are in ``names``."""
    shoulder, elbow, wrist = (names.index(n) for n in keypoints)
    return shoulder, elbow, wrist


def _arm_indices(category: dict, path: Path) -> tuple[list[tuple[int, int, int]], int]:
    """The candidate (shoulder, elbow, wrist) index triples of a category, in preference
    order, and its keypoint count."""
    names = list(_need(category, "keypoints", f"category {category.get('id')!r}", path))
    if all(n in names for n in ARM_KEYPOINTS):
        return [_indices(names, ARM_KEYPOINTS)], len(names)
    coco = [f"{side}_{joint}" for side in ("left", "right") for joint in ARM_KEYPOINTS]
    if all(n in names for n in coco):
        return [_indices(names, (f"{side}_{j}" for j in ARM_KEYPOINTS))
                for side in COCO_SIDES], len(names)
    raise AnnotationError(
        f"{path}: category {category.get('name')!r} has keypoints {names}; expected "
        f"{list(ARM_KEYPOINTS)} or COCO's person keypoints (left_/right_ shoulder, elbow, wrist)"
    )


def read_annotations(path: str | Path) -> list[ArmAnnotation]:
    """Read a COCO-keypoints JSON file: one `ArmAnnotation` per image that has a complete
    arm (all three keypoints labelled), in the file's image order.

    Raises:
        FileNotFoundError: ``path`` does not exist.
        AnnotationError: not JSON, a missing key, a keypoint list of the wrong length, an
            annotation for an unknown image or category.
    """
    path = Path(path)
    try:
        data = json.loads(path.read_text())
    except json.JSONDecodeError as err:
        raise AnnotationError(f"{path}: not valid JSON ({err})") from err
    for key in ("images", "annotations", "categories"):
        if not isinstance(data, dict) or key not in data:
            raise AnnotationError(f"{path}: a COCO-keypoints file needs a top-level {key!r} key")
    categories = {}
    for category in data["categories"]:
        cid = _need(category, "id", "a category", path)
        categories[cid] = _arm_indices(category, path)
    images = {}
    for i, image in enumerate(data["images"]):
        where = f"images[{i}]"
        images[_need(image, "id", where, path)] = image
        for key in ("file_name", "width", "height"):
            _need(image, key, where, path)
    best: dict[Any, tuple[float, ArmAnnotation]] = {}
    for i, ann in enumerate(data["annotations"]):
        where = f"annotations[{i}]"
        image_id = _need(ann, "image_id", where, path)
        if image_id not in images:
            raise AnnotationError(f"{path}: {where} refers to image_id {image_id!r}, "
                                  "which is not in 'images'")
        cid = _need(ann, "category_id", where, path)
        if cid not in categories:
            raise AnnotationError(f"{path}: {where} has category_id {cid!r}, "
                                  f"expected one of {sorted(categories)}")
        sides, count = categories[cid]
        flat = _need(ann, "keypoints", where, path)
        if not isinstance(flat, list) or len(flat) != 3 * count:
            got = len(flat) if isinstance(flat, list) else type(flat).__name__
            raise AnnotationError(f"{path}: {where} has {got} keypoint values; its category "
                                  f"has {count} keypoints, so expected {3 * count} (x, y, v)")
        triples = _numbers(flat, where, path).reshape(count, 3)
        choice = next((k for k, s in enumerate(sides) if np.all(triples[list(s), 2] > 0)),
                      None)
        if choice is None:
            continue
        points = triples[list(sides[choice]), :2]
        size = float(ann.get("area") or np.ptp(points, axis=0).prod())
        image = images[image_id]
        arm = ArmAnnotation(
            file_name=str(image["file_name"]), width=int(image["width"]),
            height=int(image["height"]), keypoints=points.astype(np.float32),
            labelled=np.ones(3, dtype=bool), image_id=int(image_id),
            render=image.get("imimic_render"),
            side=list(COCO_SIDES)[choice] if len(sides) == 2 else None,
        )
        if image_id not in best or size > best[image_id][0]:
            best[image_id] = (size, arm)
    return [best[i][1] for i in images if i in best]


def write_annotations(path: str | Path, arms: list[ArmAnnotation],
                      description: str = "imimic_gym arm keypoints") -> None:
    """Write ``arms`` as a COCO-keypoints JSON file with one ``arm`` category
    (shoulder, elbow, wrist), coordinates rounded to 1/1000 pixel. `read_annotations`
    reads it back."""
    images, annotations = [], []
    for i, arm in enumerate(arms):
        image = {"id": arm.image_id, "file_name": arm.file_name, "width": arm.width,
                 "height": arm.height}
        if arm.render is not None:
            image["imimic_render"] = arm.render
        images.append(image)
        flat: list[float] = []
        for (x, y), labelled in zip(arm.keypoints.tolist(), arm.labelled.tolist(), strict=True):
            flat += [round(x, 3), round(y, 3), 2 if labelled else 0]
        x0, y0 = arm.keypoints.min(axis=0).tolist()
        x1, y1 = arm.keypoints.max(axis=0).tolist()
        annotations.append({
            "id": i + 1, "image_id": arm.image_id, "category_id": 1, "keypoints": flat,
            "num_keypoints": int(arm.labelled.sum()), "iscrowd": 0,
            "bbox": [round(x0, 3), round(y0, 3), round(x1 - x0, 3), round(y1 - y0, 3)],
            "area": round((x1 - x0) * (y1 - y0), 3),
        })
    data = {
        "info": {"description": description},
        "images": images,
        "annotations": annotations,
        "categories": [{"id": 1, "name": "arm", "supercategory": "person",
                        "keypoints": list(ARM_KEYPOINTS), "skeleton": [[1, 2], [2, 3]]}],
    }
    write_json(path, data, indent=1)


def image_path(arm: ArmAnnotation, images_dir: str | Path) -> Path:
    """Where ``arm``'s image is: ``images_dir/file_name``.

    Raises:
        FileNotFoundError: the file is not there (the message names the path).
    """
    path = Path(images_dir) / arm.file_name
    if not path.is_file():
        raise FileNotFoundError(f"image {path} (image_id {arm.image_id}) not found; "
                                "pass the folder that holds the annotated images as --images")
    return path


def arm_keypoints_from_coco(path: str | Path, n_frames: int,
                            side: str = "auto") -> tuple[np.ndarray, np.ndarray]:
    """Shoulder, elbow and wrist per frame of a video from its COCO-keypoints file.

    Returns keypoints (T, 3, 2) float32 pixels (x, y; NaN where unlabelled) and labelled
    (T, 3) bool (v > 0), T = ``n_frames``.
    """
    if side not in ("auto", "left", "right"):
        raise ValueError(f"side must be 'auto', 'left' or 'right', got {side!r}")
    path = Path(path)
    data = _load_json(path)
    if not isinstance(data, dict) or "images" not in data or "annotations" not in data:
        raise AnnotationError(f"{path} is not COCO keypoints: it needs 'images' and "
                              "'annotations'")
    # Candidate (shoulder, elbow, wrist) triples per category, named by side.
    sides_of: dict[Any, dict[str, tuple[int, int, int]]] = {}
    for category in data.get("categories") or []:
        candidates, _ = _arm_indices(category, path)
        names = list(COCO_SIDES) if len(candidates) == 2 else ["arm"]
        sides_of[_need(category, "id", "a category", path)] = dict(zip(names, candidates,
                                                                       strict=True))
    if not sides_of:
        raise AnnotationError(f"{path}: no category lists its keypoint names ('keypoints')")
    images = sorted(data["images"], key=lambda image: _need(image, "id", "an image", path))
    key = next((k for k in ("frame_index", "frame_id") if all(k in i for i in images)), None)
    frame_of = {image["id"]: int(image[key]) if key else i for i, image in enumerate(images)}
    if frame_of and max(frame_of.values()) >= n_frames:
        raise AnnotationError(f"{path} annotates frame {max(frame_of.values())}, but the "
                              f"video has {n_frames} frames")

    names = sorted({name for sides in sides_of.values() for name in sides})
    keypoints = {n: np.full((n_frames, 3, 2), np.nan, np.float32) for n in names}
    labelled = {n: np.zeros((n_frames, 3), bool) for n in names}
    for i, annotation in enumerate(data["annotations"]):
        frame = frame_of.get(annotation.get("image_id"))
        if frame is None:
            continue
        sides = sides_of.get(annotation.get("category_id"))
        if sides is None:
            raise AnnotationError(f"{path}: annotations[{i}] has category_id "
                                  f"{annotation.get('category_id')!r}, expected one of "
                                  f"{sorted(sides_of)}")
        where = f"annotations[{i}]"
        triples = _numbers(_need(annotation, "keypoints", where, path), where,
                           path).reshape(-1, 3)
        for name, idx in sides.items():
            if max(idx) >= len(triples):
                raise AnnotationError(f"{path}: annotations[{i}] has {len(triples)} "
                                      f"keypoints, fewer than its category names")
            seen = triples[list(idx), 2] > 0
            if seen.sum() > labelled[name][frame].sum():  # the best-labelled person
                keypoints[name][frame] = np.where(seen[:, None], triples[list(idx), :2], np.nan)
                labelled[name][frame] = seen
    if side == "auto" or side not in keypoints:
        chosen = max(names, key=lambda n: labelled[n].sum())
    else:
        chosen = side
    return keypoints[chosen], labelled[chosen]


def truth_from_keypoints(keypoints: np.ndarray, labelled: np.ndarray, fps: float, n_links: int,
                         reference_direction: float, source: str = "annotations",
                         angles: np.ndarray | None = None) -> ClipTruth:
    """Truth angles from shoulder, elbow, wrist keypoints (T, 3, 2) and labels (T, 3).
    See the module docstring for the convention. ``angles`` (T, n_links) rad: the
    labelled frames' angles when the caller has them (the keypoints' angles kept within
    a robot's joint ranges, `labels.within_ranges`); None computes them from the
    keypoints. The truth's ``labelled`` marks the frames with all three keypoints."""
    if n_links not in (1, 2):
        raise ValueError(f"annotated arms have 1 or 2 links (forearm; upper arm and "
                         f"forearm), got n_links={n_links}")
    complete = labelled.all(axis=1)
    if not complete.any():
        raise AnnotationError(f"{source}: no frame has shoulder, elbow and wrist all labelled")

    # Angles within a joint range are filled in within it (the way the robot turns);
    # free ones the short way round.
    within = angles is not None
    if angles is None:
        angles = keypoints_to_angles(np.nan_to_num(keypoints), n_links, reference_direction)
    t = np.arange(len(angles))
    filled = np.empty_like(angles, dtype=np.float64)
    for j in range(n_links):
        known = angles[complete, j] if within else np.unwrap(angles[complete, j])
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
        keypoint_names=ARM_KEYPOINTS,
        labelled=complete.copy(),
    )


def truth_from_coco(path: str | Path, n_frames: int, fps: float, n_links: int,
                    reference_direction: float, side: str = "auto") -> ClipTruth:
    """`ClipTruth` of a video with ``n_frames`` frames from its COCO-keypoints file."""
    keypoints, labelled = arm_keypoints_from_coco(path, n_frames, side=side)
    return truth_from_keypoints(keypoints, labelled, fps, n_links, reference_direction,
                                source=str(path))


# The truth file `imimic clip` writes beside its video -----------------------------------
# What of a rendered clip's meta a robot is built from (`scenarios.robot_for_clip`) and
# what names the clip; the rest (its cache key, its source) describes the rendering.
TRUTH_META_KEYS = ("scenario", "seed", "n_links", "demonstrator", "reference_direction",
                   "joint_ranges", "arm_plane", "intrinsics", "arm_side")
_SPATIAL_ARRAYS = ("points3d", "points2d", "arm_angles")  # a spatial clip's 3-D truth
_TRUTH_ARRAYS = ("angles", "angular_velocity", "angular_acceleration", "keypoints",
                 "visible", "occlusion")


def write_clip_truth(path: str | Path, truth: ClipTruth, meta: dict[str, Any],
                     fps: float) -> None:
    """Write a clip's per-frame truth as JSON (`imimic clip`'s ``<scenario>-seed<k>.json``):
    ``meta``, ``fps``, ``units``, ``keypoint_names``, the `ClipTruth` arrays (angles rad,
    velocities rad/s, accelerations rad/s^2, keypoints pixels (x, y) to 1/100, visible,
    occlusion to 1/10000), ``labelled`` where the truth marks frames without one, and a
    spatial clip's 3-D truth (``points3d`` metres in the camera frame, ``points2d``
    pixels, ``arm_angles`` rad; exact, with the camera in ``meta["intrinsics"]``).
    `read_clip_truth` reads it back, and so does ``ImitateVideo-v0(clip=<the mp4>,
    annotations=<this file>)``."""
    data: dict[str, Any] = {
        "meta": meta,
        "fps": fps,
        "units": {"angles": "rad", "angular_velocity": "rad/s",
                  "angular_acceleration": "rad/s^2", "keypoints": "pixels (x, y)"},
        "keypoint_names": list(truth.keypoint_names),
        "angles": truth.angles.tolist(),
        "angular_velocity": truth.angular_velocity.tolist(),
        "angular_acceleration": truth.angular_acceleration.tolist(),
        "keypoints": truth.keypoints.round(2).tolist(),
        "visible": truth.visible.tolist(),
        "occlusion": truth.occlusion.round(4).tolist(),
    }
    if truth.labelled is not None:
        data["labelled"] = truth.labelled.tolist()
    if truth.points3d is not None and truth.points2d is not None and truth.arm_angles is not None:
        data["units"].update(points3d="metres, camera frame (x right, y down, z away)",
                             points2d="pixels (x, y)", arm_angles="rad")
        data.update(points3d=truth.points3d.tolist(), points2d=truth.points2d.tolist(),
                    arm_angles=truth.arm_angles.tolist())
    write_json(path, data, indent=None)


def is_clip_truth(data: Any) -> bool:
    """Whether parsed JSON ``data`` is a truth file of `write_clip_truth` (not COCO)."""
    return isinstance(data, dict) and "angles" in data and "images" not in data


def read_clip_truth(path: str | Path) -> tuple[ClipTruth, dict[str, Any]]:
    """The `ClipTruth` of a `write_clip_truth` file and the ``meta`` entries a robot is
    built from (`TRUTH_META_KEYS` that it has).

    Raises:
        AnnotationError: not JSON, a missing array, arrays of unequal length or shape.
    """
    path = Path(path)
    data = _load_json(path)
    if not is_clip_truth(data):
        raise AnnotationError(f"{path} is not a clip's truth file (imimic clip): it needs "
                              "an 'angles' key")
    for key in (*_TRUTH_ARRAYS, "keypoint_names"):
        _need(data, key, "the truth file", path)
    labelled = data.get("labelled")
    try:
        truth = ClipTruth(
            angles=np.asarray(data["angles"], dtype=np.float64),
            angular_velocity=np.asarray(data["angular_velocity"], dtype=np.float64),
            angular_acceleration=np.asarray(data["angular_acceleration"], dtype=np.float64),
            keypoints=np.asarray(data["keypoints"], dtype=np.float32),
            visible=np.asarray(data["visible"], dtype=bool),
            occlusion=np.asarray(data["occlusion"], dtype=np.float32),
            keypoint_names=tuple(str(n) for n in data["keypoint_names"]),
            labelled=None if labelled is None else np.asarray(labelled, dtype=bool),
            **{key: np.asarray(data[key], dtype=np.float64) for key in _SPATIAL_ARRAYS
               if key in data},
        )
    except (ValueError, TypeError) as err:
        raise AnnotationError(f"{path}: {err}") from err
    meta = data.get("meta") if isinstance(data.get("meta"), dict) else {}
    return truth, {k: meta[k] for k in TRUTH_META_KEYS if k in meta}


def _load_json(path: Path) -> Any:
    """``path``'s JSON; AnnotationError naming the file where it is missing or not JSON."""
    try:
        return json.loads(path.read_text())
    except FileNotFoundError as err:
        raise AnnotationError(f"{path}: no such annotation file") from err
    except json.JSONDecodeError as err:
        raise AnnotationError(f"{path}: not valid JSON ({err})") from err
