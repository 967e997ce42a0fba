import hashlib

import numpy as np
import pytest

from imimic_gym.clips.annotations import read_annotations, write_annotations
from imimic_gym.clips.dataset import (
    arm_in_frame,
    generate_arms,
    load_images,
    randomised_spec,
    rendered_image_path,
)
from imimic_gym.clips.demonstrator import camera_pose
from imimic_gym.clips.synthetic import render_clip

WALL_FRONT_Y = 0.595  # the backdrop's front face (demonstrator.py), metres


def background_depth(spec, keypoints: np.ndarray) -> np.ndarray:
    """Depth (m along the camera axis) of the wall or floor behind each pixel (K, 2)."""
    position, right, up, fovy = camera_pose(spec)
    forward = np.cross(up, right)
    focal = 0.5 * spec.height / np.tan(np.radians(fovy) / 2)
    rays = (forward + np.outer((keypoints[:, 0] - spec.width / 2) / focal, right)
            - np.outer((keypoints[:, 1] - spec.height / 2) / focal, up))
    wall = (WALL_FRONT_Y - position[1]) / rays[:, 1]
    floor = np.where(rays[:, 2] < 0, -position[2] / np.minimum(rays[:, 2], -1e-9), np.inf)
    return np.minimum(wall, floor)


@pytest.mark.parametrize("links", [1, 2])
def test_a_randomised_clip_has_its_keypoints_on_the_arm(links: int) -> None:
    rng = np.random.default_rng(links)
    for seed in range(3):
        spec = randomised_spec(links, 9000 + seed, rng).replace(n_frames=12)
        assert spec.appearance is not None and arm_in_frame(spec)
        clip = render_clip(spec, progress=False)
        truth = clip.truth
        assert np.all(np.isfinite(truth.angles)) and np.all(np.isfinite(truth.keypoints))
        arm = truth.keypoints[:, :3]  # shoulder, elbow, wrist
        assert np.all((arm >= 0) & (arm < np.array([spec.width, spec.height])))
        for t in range(spec.n_frames):
            cols, rows = np.rint(arm[t]).astype(int).T
            surface = clip.depth[t, rows, cols]
            # Something at least 30 cm in front of the backdrop: the person, not the wall.
            assert np.all(surface < background_depth(spec, arm[t]) - 0.3), (seed, t)


def test_randomised_specs_vary_what_they_should() -> None:
    rng = np.random.default_rng(0)
    specs = [randomised_spec(1, 9100 + i, rng) for i in range(40)]
    looks = [s.appearance for s in specs]
    assert len({look.skin for look in looks}) == 40
    assert {s.background for s in specs} == {"plain", "textured", "cluttered"}
    assert {look.long_sleeves for look in looks} == {False, True}
    assert np.ptp([look.camera_tilt for look in looks]) > 10
    assert np.ptp([s.camera_distance for s in specs]) > 1.0
    assert np.ptp([look.camera_shift for look in looks]) > 0.5


def test_a_randomised_dataset_regenerates_from_its_records(tmp_path) -> None:
    arms = generate_arms(1, 1, 91_000, 5, "random/train", progress=False, randomise=True)
    assert len(arms) == 4 and "appearance" in arms[0].render["spec"]
    write_annotations(tmp_path / "random.json", arms)
    again = read_annotations(tmp_path / "random.json")
    for arm in again:
        rendered_image_path(arm.render).unlink()  # forces a render from the record
    for arm, image in zip(again, load_images(again, progress=False), strict=True):
        assert hashlib.sha256(image.tobytes()).hexdigest() == arm.render["sha256"]
