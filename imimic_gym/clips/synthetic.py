"""Render a `ClipSpec` into a `Clip` with per-frame ground truth.

Per frame, one pass gives RGB and depth. A keypoint is visible when it projects inside
the image and nothing is rendered clearly in front of it (a z-test against that depth; a
full segmentation pass would cost as much as the image itself). When something can hide
the arm (the scene has an occluder, or a keypoint failed its z-test), a second pass draws
only the moving links, as segmentation and depth: its pixels are those the links would
cover if nothing stood in front, and those where the scene's depth is nearer by more than
a limb's thickness are hidden (by the occluder, the head, anything). Occlusion = hidden /
covered; in a frame where nothing can hide the arm it is 0 and the pass is skipped (each
pass costs ~3 ms however little it draws). The board can hide the arm only where their
images overlap: when the board's projected corners and the moving keypoints' box (grown
by a limb's width) do not overlap, the board hides nothing and needs no pass. (The pass,
when run, reports up to 1% of the links "hidden" where the upper arm's thicker capsule
meets the forearm; frames that skip it report 0, as every scene without a board does.)

A spatial arm's clip (a gesture, `clips.gestures`) also has 3-D truth: its points of
`spatial.ARM_POINTS` read from the posed scene's sites and turned into the camera frame,
projected through `spatial.Intrinsics` (in ``meta["intrinsics"]``), and the gesture's joint
angles; its planar ``angles`` are the image's reading of the keypoints
(`planar_angles`), their derivatives by finite differences.
"""

from __future__ import annotations

from dataclasses import asdict
from typing import cast

import mujoco
import numpy as np
from tqdm.auto import tqdm

from imimic_gym.clips.demonstrator import (
    ARM_SITES,
    MOVING_GROUP,
    distractor_path,
    keypoint_names,
    occluder_path,
    scene_mjcf,
)
from imimic_gym.clips.gestures import SPATIAL_JOINTS, Gesture, sample_gesture
from imimic_gym.clips.motion import MotionProfile, sample_motion
from imimic_gym.clips.scenarios import ClipSpec
from imimic_gym.clips.types import Clip, ClipTruth, depth_from_mm, depth_to_mm
from imimic_gym.kinematics import wrap_angle
from imimic_gym.render import OffscreenRenderer, project_points
from imimic_gym.spatial.camera import Intrinsics

__all__ = ["clip_meta", "planar_angles", "render_clip"]

SWAY_METRES, SWAY_RADIANS = 0.04, np.radians(3.0)


def clip_meta(spec: ClipSpec) -> dict:
    """What a consumer needs to know about a synthetic clip besides its pixels."""
    arm = spec.robot_arm()
    return {
        "source": "synthetic",
        "scenario": spec.name,
        "seed": spec.seed,
        "n_links": spec.n_links,
        "spec_key": spec.key(),
        "demonstrator": spec.demonstrator,
        "reference_direction": spec.reference_direction,
        "joint_ranges": [list(r) for r in spec.joint_ranges],
        "arm_plane": arm.plane,
    }


def planar_angles(keypoints: np.ndarray, n_links: int, reference_direction: float,
                  fps: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The planar reading (the `imimic_gym.robots.planar` convention) of a spatial arm's
    keypoints (T, 4, 2) pixels (shoulder, elbow, wrist, hand tip): link i's image
    direction minus its parent's (the reference's for the first), wrapped.

    Returns angle (T, n_links) rad in [-pi, pi), and its velocity (rad/s) and
    acceleration (rad/s^2) by central differences of the unwrapped angle."""
    k = keypoints.astype(np.float64)
    delta = np.diff(k, axis=1)[:, :n_links]
    direction = np.arctan2(-delta[..., 1], delta[..., 0])
    parent = np.concatenate([np.full((len(k), 1), reference_direction), direction[:, :-1]],
                            axis=1)
    angle = wrap_angle(direction - parent)
    if len(k) < 2:
        return angle, np.zeros_like(angle), np.zeros_like(angle)
    velocity = np.gradient(np.unwrap(angle, axis=0), 1.0 / fps, axis=0)
    return angle, velocity, np.gradient(velocity, 1.0 / fps, axis=0)


def _camera_frame(data: mujoco.MjData, camera: int, points: np.ndarray) -> np.ndarray:
    """World points (K, 3) in the camera frame of `spatial.camera` (x right, y down, z
    away from the camera; MuJoCo's camera looks along its -z with y up)."""
    local = (points - data.cam_xpos[camera]) @ data.cam_xmat[camera].reshape(3, 3)
    return local * np.array([1.0, -1.0, -1.0])


def _visible(
    depth: np.ndarray, keypoints: np.ndarray, distances: np.ndarray, tolerance: float
) -> np.ndarray:
    """Inside the image, and the rendered surface there is no nearer than the keypoint
    minus ``tolerance`` (a limb's radius and some): nothing stands in front of it."""
    h, w = depth.shape
    cols, rows = np.rint(keypoints[:, 0]).astype(int), np.rint(keypoints[:, 1]).astype(int)
    inside = (cols >= 0) & (cols < w) & (rows >= 0) & (rows < h)
    visible = np.zeros(len(keypoints), dtype=bool)
    surface = depth[rows[inside], cols[inside]]
    visible[inside] = surface >= distances[inside] - tolerance
    return visible


def _boxes_overlap(a: np.ndarray, b: np.ndarray, margin: float) -> bool:
    """Do the pixel bounding boxes of point sets ``a`` and ``b`` (K, 2) overlap, with
    ``a``'s box grown by ``margin`` pixels on every side?"""
    return bool(np.all(a.min(axis=0) - margin <= b.max(axis=0))
                and np.all(b.min(axis=0) <= a.max(axis=0) + margin))


def _pixel_box(points: np.ndarray, margin: float, height: int,
               width: int) -> tuple[int, int, int, int]:
    """(x0, y0, x1, y1), end exclusive: the pixel box around ``points`` (K, 2), grown by
    ``margin`` and clipped to the image (at least one pixel)."""
    x0, y0 = np.floor(points.min(axis=0) - margin).astype(int)
    x1, y1 = np.ceil(points.max(axis=0) + margin).astype(int) + 1
    x0, y0 = min(max(x0, 0), width - 1), min(max(y0, 0), height - 1)
    return x0, y0, max(min(x1, width), x0 + 1), max(min(y1, height), y0 + 1)


def _box_corners(model: mujoco.MjModel, data: mujoco.MjData, geom: int) -> np.ndarray:
    """(8, 3) world corners of box geom ``geom``."""
    signs = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)])
    local = signs * model.geom_size[geom]
    return data.geom_xpos[geom] + local @ data.geom_xmat[geom].reshape(3, 3).T


def render_clip(spec: ClipSpec, progress: bool = True) -> Clip:
    """Render ``spec``. Deterministic: the same spec gives a bit-identical clip.

    Returns a `Clip` with frames (T, H, W, 3) uint8 RGB, depth (T, H, W) float32 metres
    (rounded to whole millimetres, so a cached clip equals a fresh one)
    and full `ClipTruth`.
    """
    rng = np.random.default_rng(spec.seed)
    if spec.spatial:
        angles, velocity, acceleration = sample_gesture(
            cast(Gesture, spec.motion), spec.n_frames, spec.fps, rng)
    else:
        angles, velocity, acceleration = sample_motion(
            cast(MotionProfile, spec.motion), np.asarray(spec.joint_ranges), spec.n_frames,
            spec.fps, rng
        )
    model = mujoco.MjModel.from_xml_string(scene_mjcf(spec, rng))
    data = mujoco.MjData(model)
    t = np.arange(spec.n_frames) / spec.fps
    sway_phase = rng.uniform(0, 2 * np.pi, size=2)
    sway_x = spec.sway * SWAY_METRES * np.sin(2 * np.pi * 0.4 * t + sway_phase[0])
    sway_roll = spec.sway * SWAY_RADIANS * np.sin(2 * np.pi * 0.3 * t + sway_phase[1])
    occluder = occluder_path(spec, t, rng) if spec.occluder != "none" else None
    distractor = distractor_path(spec, t, rng) if spec.background == "cluttered" else None

    joints = SPATIAL_JOINTS if spec.spatial else [f"q{i + 1}" for i in range(spec.n_links)]
    arm_qpos = [model.jnt_qposadr[model.joint(name).id] for name in joints]
    sway_qpos = [model.jnt_qposadr[model.joint(n).id] for n in ("sway_x", "sway_roll")]
    names = keypoint_names(spec)
    site_ids = [model.site(f"kp_{n}").id for n in names]
    camera = model.camera("film").id
    mocap = {}
    for name in ("occluder", "distractor"):
        if mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, name) >= 0:
            mocap[name] = model.body_mocapid[model.body(name).id]
    mocap_home = data.mocap_pos.copy()
    # Depth margins (m): a keypoint sits on a limb's axis, so it tolerates the radius;
    # surfaces of touching limbs (upper arm over forearm at the elbow) differ by less.
    human = spec.demonstrator == "human"
    board = model.geom("occluder").id if occluder is not None else -1
    # Keypoints on the moving links (all but a fixed upper arm), and a limb's width in
    # pixels, generously: the board is tested against the box around them.
    moving_keypoints = slice(1 if human and spec.n_links == 1 else 0, None)
    fovy = 45 if spec.appearance is None else spec.appearance.fovy
    limb_px = 0.12 / spec.camera_distance * (spec.height / 2) / np.tan(np.radians(fovy) / 2)
    person = spec.demonstrator != "servo"  # a person (arm or hand), not the servo
    keypoint_margin, surface_margin = (0.08, 0.03) if person else (0.012, 0.008)

    h, w, n = spec.height, spec.width, spec.n_frames
    frames = np.empty((n, h, w, 3), dtype=np.uint8)
    depth = np.empty((n, h, w), dtype=np.float32)
    keypoints = np.empty((n, len(names), 2), dtype=np.float32)
    visible = np.empty((n, len(names)), dtype=bool)
    occlusion = np.zeros(n, dtype=np.float32)
    arm_sites = [model.site(name).id for name in ARM_SITES] if spec.spatial else []
    points3d = np.empty((n, len(arm_sites), 3))

    with OffscreenRenderer(model, h, w) as renderer:
        for i in tqdm(range(n), desc=f"rendering {spec.name}", disable=not progress,
                      unit="frame", leave=False):
            data.qpos[arm_qpos] = angles[i]
            data.qpos[sway_qpos] = (sway_x[i], sway_roll[i])
            if occluder is not None:
                data.mocap_pos[mocap["occluder"]] = mocap_home[mocap["occluder"]] + occluder[i]
            if distractor is not None:
                data.mocap_pos[mocap["distractor"]] = (
                    mocap_home[mocap["distractor"]] + distractor[i]
                )
            mujoco.mj_kinematics(model, data)
            mujoco.mj_camlight(model, data)
            frames[i], depth[i] = renderer.render(data, camera, depth=True)
            keypoints[i], distances = project_points(
                model, data, camera, data.site_xpos[site_ids], h, w
            )
            visible[i] = _visible(depth[i], keypoints[i], distances, keypoint_margin)
            if arm_sites:
                points3d[i] = _camera_frame(data, camera, data.site_xpos[arm_sites])
            board_near = occluder is not None and _boxes_overlap(
                keypoints[i][moving_keypoints], project_points(
                    model, data, camera, _box_corners(model, data, board), h, w)[0],
                limb_px)
            if board_near or not visible[i].all():
                x0, y0, x1, y1 = _pixel_box(keypoints[i][moving_keypoints], limb_px, h, w)
                geoms, link_depth = renderer.segment(data, camera, groups=(MOVING_GROUP,),
                                                     box=(x0, y0, x1, y1))
                covered = geoms >= 0
                hidden = covered & (depth[i][y0:y1, x0:x1] < link_depth - surface_margin)
                total = np.count_nonzero(covered)
                occlusion[i] = np.count_nonzero(hidden) / total if total else 0.0

    meta = clip_meta(spec)
    spatial: dict = {}
    if spec.spatial:
        intrinsics = Intrinsics.from_fovy(float(model.cam_fovy[camera]), w, h)
        meta["intrinsics"] = asdict(intrinsics)
        meta["arm_side"] = "left"
        spatial = {"points3d": points3d, "points2d": intrinsics.project(points3d),
                   "arm_angles": angles}
        angles, velocity, acceleration = planar_angles(
            keypoints, spec.n_links, spec.reference_direction, spec.fps)
    truth = ClipTruth(
        angles=angles,
        angular_velocity=velocity,
        angular_acceleration=acceleration,
        keypoints=keypoints,
        visible=visible,
        occlusion=occlusion,
        keypoint_names=names,
        **spatial,
    )
    depth = depth_from_mm(depth_to_mm(depth))
    return Clip(frames=frames, fps=float(spec.fps), depth=depth, truth=truth, meta=meta)
