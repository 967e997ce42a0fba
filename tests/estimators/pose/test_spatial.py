"""The 3-D pose estimators: the real pose model on rendered frames, the lift, hold and
neutral logic on hand-built keypoints, and their place in the registry."""

import math

import numpy as np
import pytest

from imimic_gym.clips.cache import load_clip
from imimic_gym.clips.scenarios import get_scenario
from imimic_gym.estimators.pose.model import KEYPOINTS, BodyKeypoints
from imimic_gym.estimators.pose.spatial import Pose3DEstimator
from imimic_gym.estimators.registry import (
    UnsupportedClipError,
    build_estimator,
    build_spatial_estimator,
    get_estimator,
)
from imimic_gym.estimators.types import EstimatorContext
from imimic_gym.evaluation import cannot_score
from imimic_gym.spatial import ArmPose, Intrinsics
from tests.estimators.pose.test_planar import ScriptedModel

CAMERA = Intrinsics.from_fovy(45, 640, 480)
FRAME = np.zeros((480, 640, 3), np.uint8)
EXACT = {"keypoint_noise": 0.0, "smoothing": None, "refine": False, "share_filter": None}


@pytest.fixture(scope="module")
def person_clip():
    return load_clip(get_scenario("default", seed=5, n_frames=12), progress=False)


@pytest.mark.parametrize("source", ["lift", "world"])
def test_the_estimator_reads_a_rendered_person(person_clip, source: str) -> None:
    h, w = person_clip.frames.shape[1:3]
    estimator = Pose3DEstimator(person_clip.fps, Intrinsics.from_fovy(45, w, h),
                                source=source)
    poses = [estimator.update(frame) for frame in person_clip.frames]
    for pose in poses:
        assert isinstance(pose, ArmPose) and np.isfinite(pose.points).all()
        assert (pose.points[:, 2] > 0).all()
        assert pose.trust == 0.0 or pose.trust >= 0.5
    read = [p for p in poses if p.trust > 0]
    assert len(read) >= len(poses) // 2
    # The demonstrator moves their left arm; a reading is an arm of about a person's size.
    for pose in read:
        assert pose.side == "left"
        assert 0.1 < pose.bone_lengths[0] < 0.6 and 0.1 < pose.bone_lengths[1] < 0.6


def test_the_depth_route_reads_the_rendered_depth(person_clip) -> None:
    assert person_clip.depth is not None
    h, w = person_clip.frames.shape[1:3]
    estimator = Pose3DEstimator(person_clip.fps, Intrinsics.from_fovy(45, w, h),
                                source="depth")
    poses = [estimator.update(frame, depth)
             for frame, depth in zip(person_clip.frames, person_clip.depth, strict=True)]
    assert all(np.isfinite(p.points).all() for p in poses)
    with pytest.raises(ValueError, match="source='depth'\\) needs each frame's depth image"):
        estimator.update(person_clip.frames[0])



def person(forearm_z: float = -0.5, confidence: float = 0.9, world: bool = True,
           fore: np.ndarray | None = None) -> tuple[BodyKeypoints, np.ndarray]:
    """A person 2.5 m away facing the camera, their left upper arm hanging, the forearm
    forward (toward the camera) and down (or along the unit vector ``fore``); their
    right arm hanging. The reading, and the left arm's true (7, 3) points in
    `ARM_POINTS` order."""
    half, top, bottom = 0.18, -0.25, 0.25
    points = {"left_shoulder": [half, top, 2.5], "right_shoulder": [-half, top, 2.5],
              "left_hip": [0.7 * half, bottom, 2.5], "right_hip": [-0.7 * half, bottom, 2.5]}
    if fore is None:
        fore = np.array([0.0, math.sqrt(1 - forearm_z ** 2), forearm_z])
    for side, x in (("left", half), ("right", -half)):
        points[f"{side}_elbow"] = [x, top + 0.29, 2.5]
        direction = fore if side == "left" else np.array([0, 1.0, 0])
        points[f"{side}_wrist"] = list(np.array(points[f"{side}_elbow"]) + 0.25 * direction)
        points[f"{side}_hand"] = list(np.array(points[f"{side}_wrist"]) + 0.09 * direction)
    xyz = np.array([points[name] for name in KEYPOINTS])
    hips = 0.5 * (xyz[KEYPOINTS.index("left_hip")] + xyz[KEYPOINTS.index("right_hip")])
    body = BodyKeypoints(points=CAMERA.project(xyz), confidence=np.full(len(KEYPOINTS),
                                                                         confidence),
                         depth=(xyz[:, 2] - hips[2]) * CAMERA.fx / 2.5 / CAMERA.width,
                         world=xyz - hips if world else None)
    names = ("left_shoulder", "left_elbow", "left_wrist", "left_hand", "right_shoulder",
             "left_hip", "right_hip")
    return body, np.array([points[name] for name in names])


def test_the_lift_through_the_estimator_is_exact_on_exact_keypoints() -> None:
    body, truth = person()
    for source in ("lift", "world"):
        estimator = Pose3DEstimator(30.0, CAMERA, arm="left", source=source,
                                    model=ScriptedModel([body]), lift=EXACT)
        pose = estimator.update(FRAME)
        np.testing.assert_allclose(pose.points, truth, atol=1e-6)
        assert pose.side == "left" and pose.trust == pytest.approx(0.9)
        assert math.degrees(pose.elbow_flexion) == pytest.approx(30.0)


def test_an_elbow_read_past_its_range_reads_as_bent_as_it_can_be() -> None:
    """Keypoints that fold the forearm 160 degrees from the upper arm (the pose model's
    full curl) read 150, an adult elbow's most, with the lift's points kept; pose-world,
    the baseline, keeps MediaPipe's own."""
    fold = math.radians(160.0)
    body, truth = person(fore=np.array([math.sin(fold), math.cos(fold), 0.0]))
    for source, flexion in (("lift", 150.0), ("world", 160.0)):
        estimator = Pose3DEstimator(30.0, CAMERA, arm="left", source=source,
                                    model=ScriptedModel([body]), lift=EXACT)
        pose = estimator.update(FRAME)
        np.testing.assert_allclose(pose.points, truth, atol=1e-6)
        assert math.degrees(pose.elbow_flexion) == pytest.approx(flexion)


def test_intrinsics_follow_the_frames_size() -> None:
    body, truth = person()
    half = BodyKeypoints(points=body.points / 2, confidence=body.confidence, depth=body.depth,
                         world=body.world)
    estimator = Pose3DEstimator(30.0, CAMERA, arm="left", model=ScriptedModel([half]),
                                lift=EXACT)
    pose = estimator.update(np.zeros((240, 320, 3), np.uint8))
    np.testing.assert_allclose(pose.points, truth, atol=1e-6)


def test_nobody_in_view_gives_the_neutral_pose_then_the_last_one_held() -> None:
    body, _ = person()
    unsure, _ = person(confidence=0.3)
    bodies = [None, body, None, unsure, body]
    estimator = Pose3DEstimator(30.0, CAMERA, model=ScriptedModel(bodies))
    poses = [estimator.update(FRAME) for _ in bodies]
    assert poses[0].trust == 0.0 and poses[0].side == "right"  # before any reading
    assert poses[0].elbow_flexion == 0.0 and poses[0].upper_arm[1] == pytest.approx(1.0)
    assert poses[1].trust > 0
    for held in poses[2:4]:
        assert held.trust == 0.0
        np.testing.assert_array_equal(held.points, poses[1].points)
    assert poses[4].trust > 0
    estimator.reset()
    assert estimator.update(FRAME).trust == 0.0  # the script's first frame: nobody


def test_the_world_route_without_world_landmarks_holds() -> None:
    body, _ = person()
    bare, _ = person(world=False)
    estimator = Pose3DEstimator(30.0, CAMERA, arm="left", source="world",
                                model=ScriptedModel([body, bare]))
    first, second = estimator.update(FRAME), estimator.update(FRAME)
    assert first.trust > 0 and second.trust == 0.0
    np.testing.assert_array_equal(second.points, first.points)


def test_settings_are_checked() -> None:
    with pytest.raises(ValueError, match="source must be one of"):
        Pose3DEstimator(30.0, source="stereo", model=ScriptedModel([]))
    with pytest.raises(ValueError, match="fps must be a positive number"):
        Pose3DEstimator(0.0, model=ScriptedModel([]))


PLANAR = EstimatorContext(fps=30.0, link_parents=(-1,), joint_ranges=((-1.0, 1.0),),
                          reference_direction=-math.pi / 2)
SPATIAL = EstimatorContext(fps=25.0, link_parents=(-1,), joint_ranges=((-1.0, 1.0),),
                           reference_direction=-math.pi / 2, spatial=True,
                           intrinsics=CAMERA)


def test_the_registry_keeps_spatial_and_planar_apart() -> None:
    for name in ("pose3d", "pose3d-depth", "pose-world"):
        entry = get_estimator(name)
        assert entry.spatial
        assert entry.unsupported(PLANAR) == (f"estimator {name!r} reads the arm in 3-D; this "
                                             "clip is planar (one moving link)")
        assert entry.unsupported(SPATIAL) is None
        with pytest.raises(UnsupportedClipError, match="reads the arm in 3-D"):
            build_estimator(name, PLANAR)
        with pytest.raises(ValueError, match="is spatial: build it with build_spatial"):
            build_estimator(name, SPATIAL)
    assert get_estimator("pose").unsupported(SPATIAL) == (
        "estimator 'pose' gives planar joint angles; this clip's arm moves in 3-D")
    assert cannot_score("default", "pose3d") == ("estimator 'pose3d' reads the arm in 3-D; "
                                                 "this clip is planar (one moving link)")


@pytest.mark.parametrize(("name", "params", "source"), [
    ("pose3d", {}, "lift"), ("pose3d", {"source": "depth"}, "depth"),
    ("pose3d-depth", {}, "depth"), ("pose-world", {"arm": "left"}, "world")])
def test_spatial_entries_build_their_estimator(name, params, source) -> None:
    estimator = build_spatial_estimator(name, SPATIAL, **params)
    assert isinstance(estimator, Pose3DEstimator)
    assert (estimator.source, estimator.fps, estimator.intrinsics) == (source, 25.0, CAMERA)
    with pytest.raises(ValueError, match="does not take window"):
        build_spatial_estimator(name, SPATIAL, window=3)
