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
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

__all__ = [
    "ARM_KEYPOINTS",
    "AnnotationError",
    "ArmAnnotation",
    "image_path",
    "read_annotations",
    "write_annotations",
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
    """

    file_name: str
    width: int
    height: int
    keypoints: np.ndarray
    labelled: np.ndarray
    image_id: int
    render: dict[str, Any] | None = field(default=None, compare=False)


def _need(entry: dict, key: str, where: str, path: Path) -> Any:
    if not isinstance(entry, dict) or key not in entry:
        raise AnnotationError(f"{path}: {where} has no {key!r} key")
    return entry[key]


def _arm_indices(category: dict, path: Path) -> tuple[list[tuple[int, int, int]], int]:
    """The candidate (shoulder, elbow, wrist) index triples of a category, in preference
    order, and its keypoint count."""
    names = list(_need(category, "keypoints", f"category {category.get('id')!r}", path))
    if all(n in names for n in ARM_KEYPOINTS):
        return [tuple(names.index(n) for n in ARM_KEYPOINTS)], len(names)
    coco = [f"{side}_{joint}" for side in ("left", "right") for joint in ARM_KEYPOINTS]
    if all(n in names for n in coco):
        return [tuple(names.index(f"{side}_{j}") for j in ARM_KEYPOINTS)
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
        triples = np.asarray(flat, dtype=np.float64).reshape(count, 3)
        side = next((s for s in sides if np.all(triples[list(s), 2] > 0)), None)
        if side is None:
            continue
        points = triples[list(side), :2]
        size = float(ann.get("area") or np.ptp(points, axis=0).prod())
        image = images[image_id]
        arm = ArmAnnotation(
            file_name=str(image["file_name"]), width=int(image["width"]),
            height=int(image["height"]), keypoints=points.astype(np.float32),
            labelled=np.ones(3, dtype=bool), image_id=int(image_id),
            render=image.get("imimic_render"),
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
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    Path(path).write_text(json.dumps(data, indent=1) + "\n")


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
