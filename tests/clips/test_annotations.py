import json
import re
from pathlib import Path

import numpy as np
import pytest

from imimic_gym.clips.annotations import (
    AnnotationError,
    ArmAnnotation,
    image_path,
    read_annotations,
    write_annotations,
)
from imimic_gym.clips.dataset import DEFAULT_ANNOTATIONS, load_images


def arm(image_id: int, points: list[list[float]], render: dict | None = None) -> ArmAnnotation:
    return ArmAnnotation(file_name=f"img{image_id}.png", width=320, height=240,
                         keypoints=np.array(points, dtype=np.float32),
                         labelled=np.ones(3, dtype=bool), image_id=image_id, render=render)


def coco_person_file(path: Path, people: list[list[int]]) -> Path:
    """A COCO person file with one image and the given 51-value keypoint lists."""
    names = ["nose", "left_eye", "right_eye", "left_ear", "right_ear", "left_shoulder",
             "right_shoulder", "left_elbow", "right_elbow", "left_wrist", "right_wrist",
             "left_hip", "right_hip", "left_knee", "right_knee", "left_ankle", "right_ankle"]
    path.write_text(json.dumps({
        "images": [{"id": 7, "file_name": "p.jpg", "width": 640, "height": 480}],
        "annotations": [{"id": i, "image_id": 7, "category_id": 1, "keypoints": k,
                         "area": 1000.0 * (i + 1)} for i, k in enumerate(people)],
        "categories": [{"id": 1, "name": "person", "keypoints": names}],
    }))
    return path


def test_write_then_read_gives_the_same_arms(tmp_path: Path) -> None:
    arms = [arm(1, [[10.5, 20.25], [30.125, 40.0], [50.0, 60.0]], render={"frame_index": 3}),
            arm(2, [[1.0, 2.0], [3.0, 4.0], [5.0, 6.0]])]
    write_annotations(tmp_path / "a.json", arms)
    back = read_annotations(tmp_path / "a.json")
    assert [a.file_name for a in back] == ["img1.png", "img2.png"]
    np.testing.assert_array_equal(back[0].keypoints, arms[0].keypoints)
    assert back[0].render == {"frame_index": 3} and back[1].render is None
    assert back[0].keypoints.dtype == np.float32 and back[0].labelled.all()
    assert back[0].side is None  # an arm category has no side


def test_coco_person_takes_the_complete_side_of_the_largest_person(tmp_path: Path) -> None:
    small = [0] * 51
    small[15:18], small[21:24], small[27:30] = [1, 1, 2], [2, 2, 2], [3, 3, 2]  # left arm
    big = [0] * 51
    big[18:21], big[24:27], big[30:33] = [100, 50, 2], [120, 80, 1], [130, 110, 2]  # right
    big[15:18] = [90, 50, 2]  # a left shoulder alone does not make a left arm
    arms = read_annotations(coco_person_file(tmp_path / "p.json", [small, big]))
    assert len(arms) == 1
    np.testing.assert_array_equal(arms[0].keypoints, [[100, 50], [120, 80], [130, 110]])
    assert arms[0].side == "right"
    (only_small,) = read_annotations(coco_person_file(tmp_path / "q.json", [small]))
    assert only_small.side == "left"


def test_a_person_without_a_complete_arm_is_skipped(tmp_path: Path) -> None:
    partial = [0] * 51
    partial[15:18], partial[21:24] = [1, 1, 2], [2, 2, 2]  # left shoulder and elbow only
    assert read_annotations(coco_person_file(tmp_path / "p.json", [partial])) == []


@pytest.mark.parametrize(("mutate", "message"), [
    (lambda d: d.pop("annotations"), "top-level 'annotations'"),
    (lambda d: d["images"][0].pop("file_name"), r"images\[0\] has no 'file_name'"),
    (lambda d: d["annotations"][0].update(keypoints=[1, 2, 2] * 2),
     r"annotations\[0\] has 6 keypoint values.*expected 9"),
    (lambda d: d["annotations"][0].update(image_id=99), "image_id 99"),
    (lambda d: d["categories"][0].update(keypoints=["a", "b", "c"]), "expected"),
    (lambda d: d["annotations"][0]["keypoints"].__setitem__(0, None),
     r"annotations\[0\] keypoint 0 has x = None; expected a finite number"),
    (lambda d: d["annotations"][0]["keypoints"].__setitem__(4, "12"),
     r"annotations\[0\] keypoint 1 has y = '12'"),
])
def test_malformed_files_raise_an_error_naming_the_file_and_entry(tmp_path: Path, mutate,
                                                                  message: str) -> None:
    path = tmp_path / "bad.json"
    write_annotations(path, [arm(1, [[1, 2], [3, 4], [5, 6]])])
    data = json.loads(path.read_text())
    mutate(data)
    path.write_text(json.dumps(data))
    with pytest.raises(AnnotationError, match=message) as err:
        read_annotations(path)
    assert str(path) in str(err.value)


def test_not_json_and_missing_files(tmp_path: Path) -> None:
    (tmp_path / "x.json").write_text("{not json")
    with pytest.raises(AnnotationError, match="not valid JSON"):
        read_annotations(tmp_path / "x.json")
    with pytest.raises(FileNotFoundError):
        read_annotations(tmp_path / "missing.json")


def test_a_missing_image_names_its_path(tmp_path: Path) -> None:
    photo = arm(3, [[1, 2], [3, 4], [5, 6]])
    with pytest.raises(FileNotFoundError, match=re.escape(str(tmp_path / "img3.png"))):
        image_path(photo, tmp_path)
    with pytest.raises(ValueError, match="--images"):
        load_images([photo])


def test_shipped_annotations_have_the_papers_split() -> None:
    for links in (1, 2):
        train = read_annotations(DEFAULT_ANNOTATIONS / f"arm{links}_train.json")
        test = read_annotations(DEFAULT_ANNOTATIONS / f"arm{links}_test.json")
        assert (len(train), len(test)) == (224, 76)
        assert {a.render["spec"]["n_links"] for a in train + test} == {links}
        backgrounds = {a.render["spec"]["background"] for a in train}
        assert backgrounds == {"plain", "textured", "cluttered"}
        train_clips = {a.render["spec"]["seed"] for a in train}
        assert train_clips.isdisjoint(a.render["spec"]["seed"] for a in test)


def test_shipped_images_regenerate_bit_identically() -> None:
    import hashlib

    arms = read_annotations(DEFAULT_ANNOTATIONS / "arm1_test.json")[:4]  # one clip
    images = load_images(arms, progress=False)
    for a, image in zip(arms, images, strict=True):
        assert hashlib.sha256(image.tobytes()).hexdigest() == a.render["sha256"]
        assert image.shape == (240, 320, 3) and image.dtype == np.uint8
