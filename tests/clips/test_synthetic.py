import numpy as np
import pytest

from imimic_gym.clips.scenarios import get_scenario, scenario_names
from imimic_gym.clips.synthetic import render_clip

FRAMES = 24


@pytest.fixture(scope="module")
def clips() -> dict:
    return {name: render_clip(get_scenario(name, n_frames=FRAMES), progress=False)
            for name in scenario_names()}


@pytest.mark.parametrize("name", scenario_names())
def test_clip_shapes_and_types(clips: dict, name: str) -> None:
    clip = clips[name]
    n = get_scenario(name).n_links
    assert clip.frames.shape == (FRAMES, 240, 320, 3) and clip.frames.dtype == np.uint8
    assert clip.depth.shape == (FRAMES, 240, 320) and clip.depth.dtype == np.float32
    assert clip.truth.angles.shape == (FRAMES, n)
    assert clip.fps == 30.0 and isinstance(clip.fps, float)
    assert np.all(np.isfinite(clip.depth)) and np.all(clip.depth > 0)
    assert clip.meta["scenario"] == name


@pytest.mark.parametrize("name", scenario_names())
def test_keypoints_give_the_true_angles(clips: dict, name: str) -> None:
    """The joint angle measured from the projected keypoints equals the truth: the camera
    faces the arm plane, so image angles are true angles (image y points down)."""
    clip = clips[name]
    spec = get_scenario(name)
    kp = clip.truth.keypoints.astype(np.float64)
    # Each moving link as (start keypoint, end keypoint), and its parent link.
    if spec.demonstrator == "hand":
        links = [(0, 1), (1, 2), (1, 3)]  # elbow-wrist, wrist-thumb tip, wrist-index tip
    elif spec.demonstrator == "human":
        first = 1 if spec.n_links == 1 else 0  # the upper arm is fixed for one link
        links = [(first + i, first + i + 1) for i in range(spec.n_links)]
    else:
        links = [(i, i + 1) for i in range(spec.n_links)]
    vectors = np.stack([kp[:, b] - kp[:, a] for a, b in links], axis=1)
    directions = np.arctan2(-vectors[..., 1], vectors[..., 0])  # CCW, image y is down
    parents = spec.link_parents
    relative = np.stack([
        directions[:, i] - (directions[:, p] if p >= 0 else spec.reference_direction)
        for i, p in enumerate(parents)
    ], axis=1)
    error = (relative - clip.truth.angles + np.pi) % (2 * np.pi) - np.pi
    # Body sway rolls the whole figure, so the first joint carries up to 3 degrees of it.
    tolerance = 1.0 + (3.0 if spec.sway else 0.0)
    assert np.max(np.abs(np.degrees(error))) < tolerance


def test_same_spec_gives_identical_clip() -> None:
    spec = get_scenario("exp3-forearm-low", n_frames=8, seed=5)
    a, b = render_clip(spec, progress=False), render_clip(spec, progress=False)
    assert np.array_equal(a.frames, b.frames) and np.array_equal(a.depth, b.depth)
    assert np.array_equal(a.truth.keypoints, b.truth.keypoints)
    c = render_clip(spec.replace(seed=6), progress=False)
    assert not np.array_equal(a.truth.angles, c.truth.angles)


def test_occluder_levels_hide_more_of_the_arm(clips: dict) -> None:
    def mean_occlusion(name: str) -> float:
        spec = get_scenario(name, n_frames=90)
        return float(render_clip(spec, progress=False).truth.occlusion.mean())

    none, low, high = (mean_occlusion(f"exp3-forearm-{lvl}") for lvl in ("none", "low", "high"))
    assert none < 0.01
    assert 0.02 < low < high
    assert high > 0.1


def test_hidden_keypoints_are_marked_invisible() -> None:
    clip = render_clip(get_scenario("exp3-forearm-high", n_frames=90), progress=False)
    heavy = clip.truth.occlusion > 0.5
    assert heavy.any()
    assert not clip.truth.visible[heavy].all()
    # With the moving links (forearm, hand) in full view, their keypoints are visible; the
    # shoulder, on the fixed upper arm, may still be behind the board.
    clear = clip.truth.occlusion == 0
    wrist_and_tip = [clip.truth.keypoint_names.index(k) for k in ("wrist", "hand_tip")]
    assert clip.truth.visible[clear][:, wrist_and_tip].all()


def test_lighting_darkens_the_image() -> None:
    bright = render_clip(get_scenario("default", n_frames=2, lighting=1.0), progress=False)
    dim = render_clip(get_scenario("default", n_frames=2, lighting=0.3), progress=False)
    assert dim.frames.mean() < 0.6 * bright.frames.mean()


def test_camera_distance_shrinks_the_arm() -> None:
    def arm_length_px(distance: float) -> float:
        clip = render_clip(get_scenario("default", n_frames=2, camera_distance=distance),
                           progress=False)
        kp = clip.truth.keypoints[0]
        return float(np.linalg.norm(kp[2] - kp[1]))

    near, far = arm_length_px(2.0), arm_length_px(4.0)
    assert near / far == pytest.approx(2.0, rel=0.1)


def test_depth_matches_the_camera_distance() -> None:
    spec = get_scenario("exp2-servo", n_frames=2)
    clip = render_clip(spec, progress=False)
    # Straight down onto the table top (z = 0): most pixels are camera_distance away.
    assert np.median(clip.depth[0]) == pytest.approx(spec.camera_distance, abs=0.002)


def test_resolution_knob() -> None:
    clip = render_clip(get_scenario("default", n_frames=2, height=120, width=160), progress=False)
    assert clip.frames.shape == (2, 120, 160, 3)


def test_an_existing_scenario_renders_as_before_appearance_existed() -> None:
    """Key and first frame of a named scenario, computed on main before
    `ClipSpec.appearance` existed (the shipped dataset's images are checked the same way
    in test_annotations.py, against the SHA-256 each record holds)."""
    import hashlib

    spec = get_scenario("exp1-noisy-fast", n_frames=2)
    clip = render_clip(spec, progress=False)
    assert spec.key() == "f114dadf38b33eadd544"
    assert hashlib.sha256(clip.frames[0].tobytes()).hexdigest() == (
        "9166024bf5eca03b6f1d21b4514e24d39a0aa45b8f2833cfdd1973fdec07de57")


@pytest.mark.parametrize("name", ["exp1-noisy-fast", "chain-2", "exp4-hand"])
def test_the_default_appearance_is_the_scene_without_one(name: str) -> None:
    from imimic_gym.clips.scenarios import Appearance

    spec = get_scenario(name, n_frames=2)
    plain = render_clip(spec, progress=False)
    dressed = render_clip(spec.replace(appearance=Appearance()), progress=False)
    assert np.array_equal(plain.frames, dressed.frames)
    assert np.array_equal(plain.truth.keypoints, dressed.truth.keypoints)
