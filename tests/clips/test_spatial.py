"""The spatial demonstrator: its 3-D truth agrees with itself, with the camera and with
the rendered scene; each named gesture does what its name says."""

import math

import mujoco
import numpy as np
import pytest

from imimic_gym.clips.cache import load_clip
from imimic_gym.clips.demonstrator import scene_mjcf
from imimic_gym.clips.gestures import GESTURES, SPATIAL_JOINT_RANGES, sample_gesture
from imimic_gym.clips.scenarios import (
    Appearance,
    ClipSpec,
    get_scenario,
    person_look,
    scenario_names,
)
from imimic_gym.clips.synthetic import render_clip
from imimic_gym.robots.planar import fmt
from imimic_gym.spatial import ARM_POINTS, ArmPose, angle_between
from imimic_gym.spatial.truth import arm_poses, clip_intrinsics

SPATIAL = ["spatial-reach", "spatial-cup", "spatial-raise", "spatial-curl", "spatial-wave",
           "spatial"]
SEEDS = (0, 1)
S, E, W, H, OS, HIP, OHIP = range(7)
UPPER_ARM, FOREARM, WRIST_TO_KNUCKLE = 0.30, 0.27, 0.09


@pytest.fixture(scope="module")
def clips() -> dict:
    """Every spatial scenario at two development seeds, whole clips (150 frames)."""
    return {(name, seed): render_clip(get_scenario(name, seed=seed), progress=False)
            for name in SPATIAL for seed in SEEDS}


def test_the_spatial_scenarios_are_registered() -> None:
    assert set(SPATIAL) <= set(scenario_names())
    for name in SPATIAL:
        spec = get_scenario(name)
        assert spec.spatial and spec.body == "person" and spec.demonstrator == "human"


def test_truth_shapes_and_camera(clips: dict) -> None:
    clip = clips["spatial", 0]
    truth = clip.truth
    assert truth.points3d.shape == (150, len(ARM_POINTS), 3)
    assert truth.points2d.shape == (150, len(ARM_POINTS), 2)
    assert truth.arm_angles.shape == (150, 5)
    camera = clip_intrinsics(clip)
    assert (camera.width, camera.height, camera.cx, camera.cy) == (320, 240, 160.0, 120.0)
    # 45 degrees vertical field of view: f = 120 / tan(22.5 degrees).
    assert camera.fx == camera.fy == pytest.approx(120 / math.tan(math.radians(22.5)))
    assert clip.meta["arm_side"] == "left"


@pytest.mark.parametrize("name", SPATIAL)
def test_the_points_project_onto_their_pixels_and_the_keypoints(clips: dict,
                                                                name: str) -> None:
    """The 3-D points through the intrinsics give the 2-D truth, and agree with the
    keypoints MuJoCo's camera projects (shoulder, elbow, wrist): measured 1.5e-5 px apart
    at most, the keypoints' float32 round-off (issue 40: a floor of 0.001 px)."""
    clip = clips[name, 0]
    truth = clip.truth
    projected = clip_intrinsics(clip).project(truth.points3d)
    assert np.max(np.abs(projected - truth.points2d)) < 1e-9
    assert np.max(np.abs(truth.points2d[:, :3] - truth.keypoints[:, :3])) < 0.001
    assert np.all(truth.points3d[..., 2] > 0.9)  # in front of the camera, a metre away


@pytest.mark.parametrize("name", SPATIAL)
def test_bones_keep_their_lengths(clips: dict, name: str) -> None:
    points = clips[name, 0].truth.points3d
    lengths = {"upper arm": (S, E, UPPER_ARM), "forearm": (E, W, FOREARM),
               "hand": (W, H, WRIST_TO_KNUCKLE)}
    for label, (a, b, length) in lengths.items():
        bone = np.linalg.norm(points[:, b] - points[:, a], axis=1)
        assert np.max(np.abs(bone - length)) < 1e-9, label
    shoulders = np.linalg.norm(points[:, S] - points[:, OS], axis=1)
    hips = np.linalg.norm(points[:, HIP] - points[:, OHIP], axis=1)
    assert np.ptp(shoulders) < 1e-9 and np.ptp(hips) < 1e-9
    assert shoulders[0] == pytest.approx(0.42) and hips[0] == pytest.approx(0.2)


@pytest.mark.parametrize("name", SPATIAL)
def test_the_depth_image_shows_the_elbow_where_the_truth_puts_it(clips: dict,
                                                                name: str) -> None:
    """Where the forearm lies across the view (within 45 degrees of the image plane) and
    nothing hides the elbow, the rendered surface at the projected elbow lies in front of
    the joint by about a limb's radius (under 7 cm: the arm's 4-5 cm, and up to 2 where a
    bent elbow's forearm passes in front of the joint): the arm's skin, not the wall
    behind it, nor anything well in front."""
    clip = clips[name, 0]
    truth = clip.truth
    forearm = truth.points3d[:, W] - truth.points3d[:, E]
    seen = truth.visible[:, 1] & (np.abs(forearm[:, 2]) < np.sin(np.radians(45)) * FOREARM)
    assert seen.sum() >= 20
    cols, rows = np.rint(truth.points2d[seen, E]).astype(int).T
    gap = truth.points3d[seen, E, 2] - clip.depth[np.flatnonzero(seen), rows, cols]
    assert np.all(gap > 0.0) and np.all(gap < 0.07), (gap.min(), gap.max())


def test_the_arm_frame_is_the_body_facing_the_camera(clips: dict) -> None:
    """The person stands facing the camera, upright: the left arm's frame is forward =
    towards the camera (-z), outward = image right (+x), up = image up (-y)."""
    expected = np.array([[0.0, 0.0, -1.0], [1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])
    for pose in arm_poses(clips["spatial", 0]):
        assert np.max(np.abs(pose.arm_frame() - expected)) < 1e-9


def _rotation(axis: tuple[float, float, float], angle: float) -> np.ndarray:
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + math.sin(angle) * k + (1 - math.cos(angle)) * k @ k


@pytest.mark.parametrize("name", SPATIAL)
def test_the_joint_angles_give_the_points_in_the_stated_order(clips: dict, name: str) -> None:
    """Forward kinematics written from `clips.gestures`' description (body frame: the
    person faces -y, the left arm's outward is +x, up +z; flexion, then abduction, then
    rotation about the upper arm, then the elbow, then the wrist) gives the truth's
    directions. The camera looks along +y with image right +x: camera = (x, -z, y)."""
    truth = clips[name, 0].truth
    to_camera = np.array([[1.0, 0, 0], [0, 0, -1.0], [0, 1.0, 0]])
    for q, points in zip(truth.arm_angles, truth.points3d, strict=True):
        flexion, abduction, rotation, elbow, wrist = q
        shoulder = (_rotation((-1, 0, 0), flexion) @ _rotation((0, -1, 0), abduction)
                    @ _rotation((0, 0, -1), rotation))
        forearm = shoulder @ _rotation((-1, 0, 0), elbow)
        hand = forearm @ _rotation((0, 1, 0), wrist)
        down = np.array([0.0, 0.0, -1.0])
        for frame, (a, b) in ((shoulder, (S, E)), (forearm, (E, W)), (hand, (W, H))):
            direction = points[b] - points[a]
            expected = to_camera @ frame @ down
            assert np.max(np.abs(direction / np.linalg.norm(direction) - expected)) < 1e-9


def test_one_seed_gives_one_clip_and_another_seed_another(clips: dict) -> None:
    spec = get_scenario("spatial", seed=0, n_frames=20)
    a, b = render_clip(spec, progress=False), render_clip(spec, progress=False)
    assert np.array_equal(a.frames, b.frames) and np.array_equal(a.depth, b.depth)
    for name in ("points3d", "points2d", "arm_angles", "angles", "keypoints"):
        assert np.array_equal(getattr(a.truth, name), getattr(b.truth, name)), name
    assert np.array_equal(a.truth.points3d, clips["spatial", 0].truth.points3d[:20])
    assert not np.array_equal(clips["spatial", 0].truth.arm_angles,
                              clips["spatial", 1].truth.arm_angles)


def test_the_cache_gives_back_the_3d_truth_bit_for_bit(tmp_path, monkeypatch) -> None:
    monkeypatch.setenv("IMIMIC_CACHE_DIR", str(tmp_path))
    spec = get_scenario("spatial-wave", seed=2, n_frames=12)
    fresh = load_clip(spec, progress=False)
    cached = load_clip(spec, progress=False)  # read back from the file just written
    assert len(list(tmp_path.glob("*.npz"))) == 1
    for name in ("points3d", "points2d", "arm_angles", "angles", "angular_velocity",
                 "keypoints"):
        got, want = getattr(cached.truth, name), getattr(fresh.truth, name)
        assert got.dtype == want.dtype and got.tobytes() == want.tobytes(), name
    assert cached.meta["intrinsics"] == fresh.meta["intrinsics"]
    assert clip_intrinsics(cached) == clip_intrinsics(fresh)


def test_the_key_covers_the_body_the_gesture_and_the_persons_looks() -> None:
    spec = get_scenario("spatial-reach")
    keys = {spec.key(), spec.replace(body="mannequin").key(), spec.replace(motion="wave").key(),
            spec.replace(appearance=Appearance()).key(),
            spec.replace(appearance=Appearance(hair=(0.9, 0.8, 0.3))).key(),
            spec.replace(appearance=Appearance(long_hair=True)).key(),
            spec.replace(appearance=Appearance(build=1.1)).key(),
            spec.replace(appearance=Appearance(shoes=(0.5, 0.1, 0.1))).key()}
    assert len(keys) == 8
    # A default appearance records as it did before the person's fields existed.
    assert set(ClipSpec(appearance=Appearance()).record()["appearance"]) == {
        "skin", "shirt", "pants", "long_sleeves", "wall", "tile", "floor", "tile_size",
        "clutter", "light_direction", "light_colour", "camera_height", "camera_tilt",
        "camera_shift", "fovy"}


@pytest.mark.parametrize(
    ("fields", "message"),
    [({"motion": "wave", "demonstrator": "servo"}, "the spatial arm .* got demonstrator 'servo'"),
     ({"motion": "reach", "n_links": 1}, r"the spatial arm \(motion 'reach'\) .* with 1"),
     ({"body": "person", "demonstrator": "hand", "n_links": 3},
      "the person body is a human demonstrator's; got demonstrator 'hand'"),
     ({"body": "robot", "motion": "reach", "n_links": 2}, "body must be one of")],
)
def test_bad_spatial_specs_are_named(fields: dict, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        ClipSpec(**fields)


def test_a_bad_build_is_named() -> None:
    with pytest.raises(ValueError, match=r"appearance build must be 0\.85-1\.2, got 1\.5"):
        Appearance(build=1.5)


def test_a_planar_clip_has_no_3d_truth() -> None:
    clip = render_clip(get_scenario("default", n_frames=2), progress=False)
    assert clip.truth.points3d is None and "intrinsics" not in clip.meta
    with pytest.raises(ValueError, match="'default' has no 3-D truth"):
        arm_poses(clip)
    with pytest.raises(ValueError, match="'default' states no camera intrinsics"):
        clip_intrinsics(clip)


def test_a_resized_clip_keeps_its_truth_consistent(clips: dict) -> None:
    clip = clips["spatial-raise", 0].resized(120, 160)
    truth = clip.truth
    assert np.max(np.abs(clip_intrinsics(clip).project(truth.points3d) - truth.points2d)) < 1e-9
    assert clip_intrinsics(clip).width == 160


# What each gesture does, checked on its whole clip at every development seed used here.
def test_reach_brings_the_wrist_towards_the_camera(clips: dict) -> None:
    """The wrist's depth drops by at least 35 cm, ending up in front of the shoulder."""
    for seed in SEEDS:
        points = clips["spatial-reach", seed].truth.points3d
        z = points[:, W, 2]
        assert z.max() - z.min() > 0.35
        nearest = int(np.argmin(z))
        assert points[nearest, S, 2] - z[nearest] > 0.45


def _arm_frame_directions(poses: list[ArmPose], a: int, b: int) -> np.ndarray:
    """(T, 3) unit directions point a -> b in each frame's arm frame (fwd, out, up)."""
    return np.stack([pose.in_arm_frame((pose.points[b] - pose.points[a])
                                       / np.linalg.norm(pose.points[b] - pose.points[a]))
                     for pose in poses])


def test_raise_lifts_the_upper_arm_sideways_above_the_shoulder(clips: dict) -> None:
    """The upper arm's elevation from hanging exceeds 100 degrees, sideways (its outward
    part larger than its forward part)."""
    for seed in SEEDS:
        upper = _arm_frame_directions(arm_poses(clips["spatial-raise", seed]), S, E)
        elevation = np.degrees(np.arccos(np.clip(-upper[:, 2], -1, 1)))
        top = int(np.argmax(elevation))
        assert elevation[top] > 100
        assert upper[top, 1] > 2 * abs(upper[top, 0])


def test_curl_bends_the_elbow_through_100_degrees_with_the_upper_arm_down(
        clips: dict) -> None:
    for seed in SEEDS:
        poses = arm_poses(clips["spatial-curl", seed])
        flexion = np.degrees([pose.elbow_flexion for pose in poses])
        assert flexion.max() - flexion.min() > 100
        upper = _arm_frame_directions(poses, S, E)
        assert np.degrees(np.arccos(np.clip(-upper[:, 2], -1, 1))).max() < 25


def _mouth(spec: ClipSpec) -> np.ndarray:
    """The mouth's centre in the camera frame: the scene's own geom, posed."""
    model = mujoco.MjModel.from_xml_string(scene_mjcf(spec, np.random.default_rng(0)))
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    mujoco.mj_camlight(model, data)
    camera = model.camera("film").id
    local = (data.geom_xpos[model.geom("mouth").id] - data.cam_xpos[camera]) @ data.cam_xmat[
        camera].reshape(3, 3)
    return local * np.array([1.0, -1.0, -1.0])


def test_cup_brings_the_hand_to_the_mouth(clips: dict) -> None:
    """The hand's knuckles come within 10 cm of the mouth, from over 50 cm at rest."""
    for seed in SEEDS:
        mouth = _mouth(get_scenario("spatial-cup", seed=seed))
        distance = np.linalg.norm(clips["spatial-cup", seed].truth.points3d[:, H] - mouth,
                                  axis=1)
        assert distance.min() < 0.10 and distance[0] > 0.5


def _reversals(series: np.ndarray, threshold: float) -> int:
    """How many times ``series`` turns back by more than ``threshold``."""
    direction, extreme, count = 0.0, series[0], 0
    for value in series[1:]:
        if direction == 0:
            if abs(value - series[0]) > threshold:
                direction, extreme = np.sign(value - series[0]), value
        elif (value - extreme) * direction > 0:
            extreme = value
        elif abs(value - extreme) > threshold:
            direction, extreme, count = -direction, value, count + 1
    return count


def test_wave_swings_the_raised_forearm_side_to_side(clips: dict) -> None:
    """With the wrist above the elbow, the forearm's sideways lean in the image turns back
    at least four times, by more than 25 degrees each time."""
    for seed in SEEDS:
        truth = clips["spatial-wave", seed].truth
        forearm = truth.points3d[:, W] - truth.points3d[:, E]
        raised = forearm[:, 1] < -0.1  # the wrist above the elbow (image y is down)
        lean = np.degrees(np.arctan2(forearm[:, 0], -forearm[:, 1]))[raised]
        assert _reversals(lean, 25.0) >= 4


def test_mix_strings_different_gestures_per_seed(clips: dict) -> None:
    a, b = (clips["spatial", seed].truth.arm_angles for seed in SEEDS)
    assert np.degrees(np.max(np.abs(a - b))) > 30


@pytest.mark.parametrize("gesture", GESTURES)
def test_gestures_stay_in_human_ranges_and_move_smoothly(gesture: str) -> None:
    ranges = np.array(SPATIAL_JOINT_RANGES)
    step = 1e-3  # s: sampled finely, so finite differences are the derivatives
    for seed in range(40):
        angle, velocity, acceleration = sample_gesture(gesture, 5000, 1 / step,
                                                       np.random.default_rng(seed))
        assert np.all(angle >= ranges[:, 0]) and np.all(angle <= ranges[:, 1])
        # The analytic velocity is the angle's derivative, and both are continuous
        # (minimum-jerk joins): per millisecond the velocity changes by under 0.2 rad/s,
        # the acceleration by under 10 rad/s^2 (a jump would be tens of times that).
        assert np.max(np.abs(np.gradient(angle, step, axis=0)[1:-1] - velocity[1:-1])) < 1e-3
        assert np.max(np.abs(np.diff(velocity, axis=0))) < 0.2
        assert np.max(np.abs(np.diff(acceleration, axis=0))) < 10
    assert np.all(velocity[0] == 0) and np.all(acceleration[0] == 0)


@pytest.mark.parametrize("name", SPATIAL)
def test_recorded_joint_angles_are_human(clips: dict, name: str) -> None:
    ranges = np.array(SPATIAL_JOINT_RANGES)
    for seed in SEEDS:
        angles = clips[name, seed].truth.arm_angles
        assert np.all(angles >= ranges[:, 0]) and np.all(angles <= ranges[:, 1])
        # elbow flexion from the points equals the elbow joint's angle
        poses = arm_poses(clips[name, seed])
        flexion = np.array([pose.elbow_flexion for pose in poses])
        assert np.max(np.abs(flexion - angles[:, 3])) < 1e-9


def test_arm_poses_read_the_truth_frame_by_frame(clips: dict) -> None:
    clip = clips["spatial-curl", 0]
    poses = arm_poses(clip)
    assert len(poses) == len(clip)
    assert all(p.side == "left" and p.trust == 1.0 and np.all(p.confidence == 1)
               for p in poses)
    assert np.array_equal(poses[7].points, clip.truth.points3d[7])
    assert np.array_equal(poses[7].pixels, clip.truth.points2d[7])
    assert angle_between(poses[7].upper_arm, clip.truth.points3d[7, E] - clip.truth.points3d[
        7, S]) < 1e-12


def test_a_person_without_an_appearance_is_dressed_by_its_seed() -> None:
    """Seeds dress the person differently (skin, hair, clothes, build); the motion a seed
    draws is the same whatever the body wears, and an explicit appearance wins."""
    looks = {person_look(seed) for seed in range(12)}
    assert len({look.skin for look in looks}) == 12 and len({look.hair for look in looks}) > 6
    assert {look.long_hair for look in looks} == {True, False}
    assert person_look(3) == person_look(3)
    spec = get_scenario("spatial-curl", seed=3, n_frames=3)
    person, mannequin = (render_clip(s, progress=False)
                         for s in (spec, spec.replace(body="mannequin")))
    assert np.array_equal(person.truth.arm_angles, mannequin.truth.arm_angles)
    chosen = Appearance(shirt=(0.9, 0.1, 0.1), hair=(0.9, 0.9, 0.1))
    mjcf = scene_mjcf(spec.replace(appearance=chosen), np.random.default_rng(0))
    assert '<material name="shirt" rgba="0.9 0.1 0.1 1"/>' in mjcf
    assert '<material name="hair" rgba="0.9 0.9 0.1 1"/>' in mjcf
    assert fmt((*person_look(3).shirt, 1.0)) in scene_mjcf(spec, np.random.default_rng(0))


def test_the_truth_follows_a_swaying_body_and_a_tilted_camera() -> None:
    """With body sway and a raised, tilted, shifted camera of another field of view, the
    points still project onto MuJoCo's keypoints and keep their lengths, and the hips
    roll with the torso (the arm frame's up leaves the camera's)."""
    look = Appearance(camera_height=0.4, camera_tilt=12.0, camera_shift=-0.2, fovy=55.0)
    clip = render_clip(get_scenario("spatial-wave", seed=4, n_frames=40, sway=1.0,
                                    appearance=look), progress=False)
    truth = clip.truth
    camera = clip_intrinsics(clip)
    assert camera.fy == pytest.approx(120 / math.tan(math.radians(27.5)))
    # measured 7.6e-6 px: float32 round-off (issue 40: a floor of 0.001 px)
    assert np.max(np.abs(truth.points2d[:, :3] - truth.keypoints[:, :3])) < 0.001
    forearm = np.linalg.norm(truth.points3d[:, W] - truth.points3d[:, E], axis=1)
    assert np.max(np.abs(forearm - FOREARM)) < 1e-9
    ups = np.array([pose.arm_frame()[2] for pose in arm_poses(clip)])
    assert np.degrees(np.max(angle_between(ups, ups[:1]))) > 2.0


def test_imimic_clips_truth_file_carries_the_3d_truth_to_a_video(tmp_path) -> None:
    """The truth JSON of `imimic clip` holds the 3-D truth exactly and the camera; a
    video loaded with it (cut to fewer frames) gives the same `ArmPose`s."""
    from imimic_gym.clips.annotations import read_clip_truth, write_clip_truth
    from imimic_gym.clips.video_load import load_video
    from imimic_gym.clips.video_writer import write_video

    clip = render_clip(get_scenario("spatial-wave", seed=1, n_frames=12), progress=False)
    write_clip_truth(tmp_path / "truth.json", clip.truth, clip.meta, clip.fps)
    truth, geometry = read_clip_truth(tmp_path / "truth.json")
    for name in ("points3d", "points2d", "arm_angles"):
        assert np.array_equal(getattr(truth, name), getattr(clip.truth, name)), name
    assert geometry["intrinsics"] == clip.meta["intrinsics"]
    video = write_video(tmp_path / "clip.mp4", clip.frames, clip.fps)
    loaded = load_video(video, tmp_path / "truth.json", max_frames=8)
    assert np.array_equal(loaded.truth.points3d, clip.truth.points3d[:8])
    assert clip_intrinsics(loaded) == clip_intrinsics(clip)
    assert [p.side for p in arm_poses(loaded)] == ["left"] * 8


def test_the_person_can_play_a_planar_scenario() -> None:
    """body="person" on a planar scenario: the same motion and keypoints as the
    mannequin's (the truth is the arm's, not the figure's), other pixels."""
    spec = get_scenario("chain-3", seed=2, n_frames=6)
    mannequin, person = (render_clip(s, progress=False)
                         for s in (spec, spec.replace(body="person")))
    assert np.array_equal(person.truth.angles, mannequin.truth.angles)
    assert np.max(np.abs(person.truth.keypoints[:, :3] - mannequin.truth.keypoints[:, :3])) < 1e-3
    assert person.truth.points3d is None
    assert not np.array_equal(person.frames, mannequin.frames)
