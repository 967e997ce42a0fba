"""`Clip` and `ClipTruth`: what every clip source produces and every consumer reads."""

from __future__ import annotations

from dataclasses import asdict, dataclass, field, replace
from typing import Any

import numpy as np

__all__ = ["MODALITIES", "Clip", "ClipTruth", "depth_from_mm", "depth_to_frame", "depth_to_mm"]

MODALITIES = ("rgb", "depth")  # what a camera gives an estimator: colour, or depth as grey


def depth_to_mm(depth: np.ndarray) -> np.ndarray:
    """Depth in metres (float32) to whole millimetres (uint16, up to 65.5 m)."""
    return np.rint(np.minimum(depth, 65.535) * np.float32(1000.0)).astype(np.uint16)


def depth_from_mm(millimetres: np.ndarray) -> np.ndarray:
    """Whole millimetres (uint16) back to metres (float32). Rendered clips pass their depth
    through both functions, so a clip read from the cache equals a fresh one bit for bit."""
    return millimetres.astype(np.float32) / np.float32(1000.0)


def depth_to_frame(depth: np.ndarray) -> np.ndarray:
    """(T, H, W) metres to (T, H, W, 3) uint8, near = bright, stretched between the clip's
    1st and 99th depth percentiles (one fixed mapping for the whole clip): the ``depth``
    modality's frames."""
    near, far = np.percentile(depth, [1, 99])
    scaled = (far - depth) / max(far - near, 1e-6)
    grey = np.clip(scaled * 255.0, 0, 255).astype(np.uint8)
    return np.repeat(grey[..., None], 3, axis=-1)


def _check(name: str, array: np.ndarray, shape: tuple[int | None, ...], dtype: Any) -> None:
    if array.dtype != dtype:
        raise ValueError(f"{name} must have dtype {np.dtype(dtype)}, got {array.dtype}")
    if array.ndim != len(shape) or any(
        want is not None and got != want for got, want in zip(array.shape, shape, strict=True)
    ):
        expected = "x".join("?" if s is None else str(s) for s in shape)
        got = "x".join(map(str, array.shape))
        raise ValueError(f"{name} must have shape {expected}, got {got}")


@dataclass(frozen=True)
class ClipTruth:
    """Per-frame ground truth of a clip. T frames, n joints, K keypoints.

    Attributes:
        angles: (T, n) float64, joint angles in rad (DESIGN.md convention).
        angular_velocity: (T, n) float64, rad/s.
        angular_acceleration: (T, n) float64, rad/s^2.
        keypoints: (T, K, 2) float32 pixel coordinates (x = column, y = row), named by
            ``keypoint_names``.
        visible: (T, K) bool, the keypoint is inside the image and not hidden.
        occlusion: (T,) float32 in [0, 1], fraction of the moving links' pixels hidden
            by an occluder.
        keypoint_names: K names, e.g. ("shoulder", "elbow", "wrist", "hand_tip").
        points3d: a spatial arm's clip only (else None): (T, 7, 3) float64, metres in the
            camera frame (x right, y down, z away from the camera), the points of
            `spatial.ARM_POINTS` in that order (the moving arm's shoulder, elbow, wrist
            and hand knuckle, the other shoulder, this side's hip, the other hip). The
            camera is ``Clip.meta["intrinsics"]`` (`spatial.Intrinsics`' fields), the
            arm's side ``Clip.meta["arm_side"]``.
        points2d: with ``points3d``: (T, 7, 2) float64 pixels (x, y), their projections.
        arm_angles: with ``points3d``: (T, 5) float64 rad, the arm's joint angles in
            `clips.gestures.SPATIAL_JOINTS` order.
        labelled: (T,) bool, the frames whose truth was read (annotated, or read by the
            pose model); the others' angles are filled in between them and are no truth.
            None: every frame (rendered truth).
    """

    angles: np.ndarray
    angular_velocity: np.ndarray
    angular_acceleration: np.ndarray
    keypoints: np.ndarray
    visible: np.ndarray
    occlusion: np.ndarray
    keypoint_names: tuple[str, ...]
    points3d: np.ndarray | None = None
    points2d: np.ndarray | None = None
    arm_angles: np.ndarray | None = None
    labelled: np.ndarray | None = None

    def __post_init__(self) -> None:
        t, n = self.angles.shape if self.angles.ndim == 2 else (None, None)
        k = len(self.keypoint_names)
        _check("truth.angles", self.angles, (None, None), np.float64)
        _check("truth.angular_velocity", self.angular_velocity, (t, n), np.float64)
        _check("truth.angular_acceleration", self.angular_acceleration, (t, n), np.float64)
        _check("truth.keypoints", self.keypoints, (t, k, 2), np.float32)
        _check("truth.visible", self.visible, (t, k), np.bool_)
        _check("truth.occlusion", self.occlusion, (t,), np.float32)
        spatial = (self.points3d, self.points2d, self.arm_angles)
        if any(v is None for v in spatial) and any(v is not None for v in spatial):
            raise ValueError("truth.points3d, points2d and arm_angles come together: all "
                             "three or none")
        for name, value, shape in (("points3d", self.points3d, (t, 7, 3)),
                                   ("points2d", self.points2d, (t, 7, 2)),
                                   ("arm_angles", self.arm_angles, (t, 5))):
            if value is not None:
                _check(f"truth.{name}", value, shape, np.float64)
        if self.labelled is not None:
            _check("truth.labelled", self.labelled, (t,), np.bool_)

    def has_label(self, frame: int) -> bool:
        """Whether frame ``frame``'s angles were read rather than filled in."""
        return self.labelled is None or bool(self.labelled[frame])

    @property
    def n_joints(self) -> int:
        return int(self.angles.shape[1])


@dataclass(frozen=True)
class Clip:
    """A video of a demonstrator, and what is known about it.

    Attributes:
        frames: (T, H, W, 3) uint8 RGB: an array, or a `clips.video.FrameStream` (same
            dtype and shape, read forward on demand from a file or camera).
        fps: frames per second, a float (29.97 stays 29.97).
        depth: (T, H, W) float32 distance along the camera axis in metres, or None.
        truth: ground truth, or None for footage without annotations.
        meta: where the clip came from: scenario, seed, n_links, source, and for
            synthetic clips ``reference_direction`` (rad) and ``joint_ranges`` (rad) so a
            matching robot can be built.
    """

    frames: np.ndarray
    fps: float
    depth: np.ndarray | None = None
    truth: ClipTruth | None = None
    meta: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        _check("frames", self.frames, (None, None, None, 3), np.uint8)
        if len(self.frames) == 0:
            raise ValueError("a clip needs at least one frame, got 0")
        t, h, w = self.frames.shape[:3]
        if not (isinstance(self.fps, float) and self.fps > 0):
            raise ValueError(f"fps must be a positive float, got {self.fps!r}")
        if self.depth is not None:
            _check("depth", self.depth, (t, h, w), np.float32)
        if self.truth is not None and len(self.truth.angles) != t:
            raise ValueError(f"truth has {len(self.truth.angles)} frames, the clip has {t}")

    def __len__(self) -> int:
        return int(self.frames.shape[0])

    @property
    def height(self) -> int:
        return int(self.frames.shape[1])

    @property
    def width(self) -> int:
        return int(self.frames.shape[2])

    def resized(self, height: int | None, width: int | None) -> Clip:
        """This clip at ``height`` x ``width`` pixels (None keeps a side), keypoints scaled.
        Frames are resampled with area averaging, depth with nearest neighbour."""
        import cv2

        h, w = height or self.height, width or self.width
        if (h, w) == (self.height, self.width):
            return self
        frames = np.stack(
            [cv2.resize(f, (w, h), interpolation=cv2.INTER_AREA) for f in self.frames]
        )
        depth = None
        if self.depth is not None:
            depth = np.stack(
                [cv2.resize(d, (w, h), interpolation=cv2.INTER_NEAREST) for d in self.depth]
            )
        truth = self.truth
        meta = dict(self.meta)
        if truth is not None:
            scale = np.array([w / self.width, h / self.height], dtype=np.float32)
            truth = replace(truth, keypoints=(truth.keypoints * scale).astype(np.float32))
            if truth.points2d is not None:
                truth = replace(truth, points2d=truth.points2d * np.array(
                    [w / self.width, h / self.height]))
        if "intrinsics" in meta:
            from imimic_gym.spatial.camera import Intrinsics

            meta["intrinsics"] = asdict(Intrinsics(**meta["intrinsics"]).scaled(w, h))
        return Clip(frames=frames, fps=self.fps, depth=depth, truth=truth, meta=meta)

    @property
    def n_links(self) -> int:
        if self.truth is not None:
            return self.truth.n_joints
        return int(self.meta.get("n_links", 1))
