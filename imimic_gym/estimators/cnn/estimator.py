"""The paper's second method (§4): a CNN regresses shoulder, elbow and wrist from a frame,
a refiner MLP refines them; joint angles follow from the keypoints.

Decisions where the paper is vague:

- Input. The paper does not give its input size. Frames are area-averaged down to
  ``input_hw`` (60x80 for 240x320 video) and scaled to [-0.5, 0.5]: the default training
  then runs in minutes on two CPU cores. Frames of another aspect ratio are resized
  anyway (the keypoints scale with them).
- Units. Targets are keypoints in input pixels divided by the input width, so x and y
  share one scale and the loss's link lengths are true lengths.
- Widths. "Two convolution layers followed by max pooling and flatten", six hidden
  layers, ReLU, linear output: conv 5x5 (16) - pool 2 - conv 3x3 (32) - pool 2 - flatten
  - dense 64 - dense 6. The refiner: 6 - 64 - 64 - 6, ReLU, linear output.
- The CNN row of the paper's tables is the CNN after its own 10 epochs; the combined
  network then trains CNN and refiner together (100 epochs) with `keypoint_loss`.
"""

from __future__ import annotations

import json
import math
import pickle
import zipfile
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import cv2
import mujoco
import numpy as np
import torch
from torch import nn

from imimic_gym.atomic import atomic_write, write_json
from imimic_gym.checkpoints import (
    SHIPPED_CHECKPOINTS,
    CheckpointError,
    file_sha256,
    verify_checkpoint,
)
from imimic_gym.clips.annotations import keypoints_to_angles
from imimic_gym.estimators.motion import PathEstimator, TorqueModel
from imimic_gym.estimators.types import Estimate

__all__ = [
    "DEFAULT_CHECKPOINTS",
    "CNNEstimator",
    "CNNRefiner",
    "CheckpointError",
    "KeypointCNN",
    "NetConfig",
    "Refiner",
    "default_checkpoint",
    "keypoint_loss",
    "keypoints_to_angles",
    "load_model",
    "predict_keypoints",
    "save_model",
    "torch_threads",
]

DEFAULT_CHECKPOINTS = SHIPPED_CHECKPOINTS


@dataclass(frozen=True)
class NetConfig:
    """The network's shape: input (height, width) in pixels, channel and unit counts."""

    input_hw: tuple[int, int] = (60, 80)
    conv_channels: tuple[int, int] = (16, 32)
    dense_units: int = 128
    refiner_units: int = 64


class KeypointCNN(nn.Module):
    """Paper §4.1, the CNN: image (B, 3, H, W) float -> (B, 6) keypoints
    (x_s, y_s, x_e, y_e, x_w, y_w) in input widths."""

    def __init__(self, config: NetConfig = NetConfig()) -> None:
        super().__init__()
        c1, c2 = config.conv_channels
        h, w = config.input_hw
        self.features = nn.Sequential(
            nn.Conv2d(3, c1, 5, padding=2), nn.ReLU(), nn.MaxPool2d(2),
            nn.Conv2d(c1, c2, 3, padding=1), nn.ReLU(), nn.MaxPool2d(2),
            nn.Flatten(),
        )
        self.head = nn.Sequential(
            nn.Linear(c2 * (h // 4) * (w // 4), config.dense_units), nn.ReLU(),
            nn.Linear(config.dense_units, 6),
        )

    def forward(self, images: torch.Tensor) -> torch.Tensor:
        return self.head(self.features(images))


class Refiner(nn.Module):
    """Paper §4.2, the refiner network: (B, 6) keypoints -> (B, 6) refined keypoints."""

    def __init__(self, units: int = 64) -> None:
        super().__init__()
        self.layers = nn.Sequential(nn.Linear(6, units), nn.ReLU(), nn.Linear(units, units),
                                    nn.ReLU(), nn.Linear(units, 6))

    def forward(self, keypoints: torch.Tensor) -> torch.Tensor:
        return self.layers(keypoints)


class CNNRefiner(nn.Module):
    """The combined network: ``refiner(cnn(image))``; ``refine=False`` gives the CNN alone."""

    def __init__(self, config: NetConfig = NetConfig()) -> None:
        super().__init__()
        self.config = config
        self.cnn = KeypointCNN(config)
        self.refiner = Refiner(config.refiner_units)

    def forward(self, images: torch.Tensor, refine: bool = True) -> torch.Tensor:
        coarse = self.cnn(images)
        return self.refiner(coarse) if refine else coarse


def keypoint_loss(predicted: torch.Tensor, truth: torch.Tensor) -> torch.Tensor:
    """Paper Eqs. (distd)-(loss): loss = d + p, averaged over the batch.

    p is the sum of squared coordinate errors of shoulder, elbow and wrist; d the squared
    errors of the two link lengths (upper arm s-e, forearm e-w). The paper prints each
    length as sqrt(dx^2 - dy^2): a sign typo (it is not a length, and is imaginary for a
    steep link); we use the Euclidean sqrt(dx^2 + dy^2).

    Args:
        predicted, truth: (B, 6) keypoints (x_s, y_s, x_e, y_e, x_w, y_w), one unit.
    Returns:
        scalar tensor, in that unit squared.
    """
    p = ((predicted - truth) ** 2).sum(dim=1)

    def lengths(k: torch.Tensor) -> torch.Tensor:
        points = k.view(-1, 3, 2)
        # A tiny floor keeps the gradient of the length finite when two points coincide.
        return torch.sqrt(((points[:, 1:] - points[:, :-1]) ** 2).sum(dim=2) + 1e-12)

    d = ((lengths(truth) - lengths(predicted)) ** 2).sum(dim=1)
    return (p + d).mean()


def to_input(images: Iterable[np.ndarray], config: NetConfig) -> torch.Tensor:
    """(B, 3, h, w) float32 in [-0.5, 0.5] from (H, W, 3) uint8 RGB images of any size."""
    h, w = config.input_hw
    batch = np.stack([cv2.resize(im, (w, h), interpolation=cv2.INTER_AREA) for im in images])
    return torch.from_numpy(batch).permute(0, 3, 1, 2).float().div_(255.0).sub_(0.5)


def to_units(keypoints: np.ndarray, image_hw: np.ndarray, config: NetConfig) -> np.ndarray:
    """(B, 3, 2) pixels of images sized (B, 2) (height, width) -> (B, 6) input widths."""
    h, w = config.input_hw
    scale = np.array([w, h], dtype=np.float64) / np.asarray(image_hw, dtype=np.float64)[:, ::-1]
    return (keypoints * scale[:, None, :] / w).reshape(len(keypoints), 6).astype(np.float32)


def from_units(units: np.ndarray, image_hw: np.ndarray, config: NetConfig) -> np.ndarray:
    """Inverse of `to_units`: (B, 6) input widths -> (B, 3, 2) pixels."""
    h, w = config.input_hw
    scale = np.asarray(image_hw, dtype=np.float64)[:, ::-1] / np.array([w, h], dtype=np.float64)
    return units.reshape(-1, 3, 2).astype(np.float64) * w * scale[:, None, :]


@torch.no_grad()
def predict_keypoints(model: CNNRefiner, images: list[np.ndarray], refine: bool = True,
                      batch_size: int = 64) -> np.ndarray:
    """(B, 3, 2) float64 pixel keypoints (shoulder, elbow, wrist) of (H, W, 3) uint8 RGB
    images, each in its own pixels."""
    model.eval()
    out = []
    for start in range(0, len(images), batch_size):
        chunk = images[start:start + batch_size]
        units = model(to_input(chunk, model.config), refine=refine).numpy()
        hw = np.array([im.shape[:2] for im in chunk])
        out.append(from_units(units, hw, model.config))
    return np.concatenate(out) if out else np.zeros((0, 3, 2))


def save_model(model: CNNRefiner, path: str | Path, metadata: dict[str, Any]) -> None:
    """Write the state_dict to ``path`` and ``metadata`` (plus the architecture) to the
    JSON beside it (same stem). Weights are stored as float16, half the file (the shipped
    checkpoints stay small); `load_model` casts them back to float32, which moves a
    predicted keypoint by far less than a pixel."""
    path = Path(path)
    with atomic_write(path) as stream:
        torch.save({k: v.half() if v.is_floating_point() else v
                    for k, v in model.state_dict().items()}, stream)
    meta = {"architecture": asdict(model.config), **metadata, "sha256": file_sha256(path)}
    write_json(path.with_suffix(".json"), meta)


def load_model(path: str | Path) -> CNNRefiner:
    """The `CNNRefiner` saved at ``path`` (architecture from the JSON beside it, if any),
    checked against the SHA-256 that JSON records (`checkpoints.verify_checkpoint`), then
    loaded with ``torch.load(weights_only=True)``.

    Raises:
        FileNotFoundError: no file at ``path``.
        CheckpointError: altered or corrupt (its SHA-256), not a torch checkpoint
            (truncated), or its tensors do not fit the architecture.
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"checkpoint {path} not found")
    config = NetConfig()
    meta_path = path.with_suffix(".json")
    if meta_path.is_file():
        try:
            meta = json.loads(meta_path.read_text())
            arch = meta["architecture"]
            fields: dict[str, Any] = {k: tuple(v) if isinstance(v, list) else v
                                      for k, v in arch.items()}
            config = NetConfig(**fields)
        except (json.JSONDecodeError, KeyError, TypeError) as err:
            raise CheckpointError(f"checkpoint metadata {meta_path} has no valid "
                                  f"'architecture' ({err})") from err
        verify_checkpoint(path, meta)
    try:
        state = torch.load(path, map_location="cpu", weights_only=True)
    except (RuntimeError, pickle.UnpicklingError, EOFError, zipfile.BadZipFile,
            ValueError) as err:
        # torch's own text runs to several lines of advice on unpickling: its class says
        # enough, and the message stays one line.
        raise CheckpointError(f"checkpoint {path} is not a readable torch state_dict "
                              f"(corrupt or truncated? {type(err).__name__})") from err
    model = CNNRefiner(config)
    if not isinstance(state, dict):
        raise CheckpointError(f"checkpoint {path} holds a {type(state).__name__}, "
                              "expected a state_dict")
    try:
        model.load_state_dict(state)
    except RuntimeError as err:
        first = str(err).strip().splitlines()
        raise CheckpointError(f"checkpoint {path} does not fit the CNN + refiner "
                              f"architecture {config}: {' '.join(first[:3])}") from err
    return model.eval()


@contextmanager
def torch_threads(threads: int | None) -> Iterator[None]:
    """Run the block with torch's intra-op thread count set to ``threads`` (None: as it
    is), then set it back to what it was, so the caller's setting survives."""
    if threads is None:
        yield
        return
    before = torch.get_num_threads()
    torch.set_num_threads(threads)
    try:
        yield
    finally:
        torch.set_num_threads(before)


def default_checkpoint(n_links: int) -> Path:
    """The shipped checkpoint for ``n_links`` (1 or 2): ``checkpoints/cnn_arm<n>.pt``."""
    if n_links not in (1, 2):
        raise ValueError(f"shipped CNN checkpoints cover 1 or 2 links, not {n_links}")
    return DEFAULT_CHECKPOINTS / f"cnn_arm{n_links}.pt"


class CNNEstimator:
    """The CNN + refiner behind the `Estimator` interface: each frame's keypoints become
    joint angles, and the shared path estimator (`motion.py`) turns those into angular
    velocity and acceleration, and torques.

    The CNN sees one frame at a time and has no notion of occlusion: trust is 1 and
    nothing is predicted.

    Args:
        n_links: 1 (forearm) or 2 (shoulder and elbow).
        checkpoint: a checkpoint path; None takes the shipped one for ``n_links``.
        fps: frame rate, for rad/s.
        reference_direction: image direction (rad, CCW from image right) of the torso,
            for the 2-link shoulder angle.
        robot: the robot's MuJoCo model, for torques; None gives zero torque.
        refine: False skips the refiner. Only meaningful for a network whose CNN was trained
            alone: in the shipped ones CNN and refiner were trained together, and the CNN's
            output is the refiner's input, not pixel coordinates.
        threads: torch's CPU threads while it reads a frame (the previous count is set
            back after each frame); None leaves torch's own setting. One by default: a
            60x80 frame is too little work to share, and torch's default (every core)
            made `imimic mimic` several times slower, fighting the decoder and the
            simulator for the same cores.
    """

    def __init__(self, n_links: int = 1, checkpoint: str | Path | None = None,
                 fps: float = 30.0, reference_direction: float = -math.pi / 2,
                 robot: mujoco.MjModel | None = None, refine: bool = True,
                 threads: int | None = 1) -> None:
        if n_links not in (1, 2):
            raise ValueError(f"the CNN estimates 1 or 2 links, got n_links={n_links}")
        if threads is not None and not (isinstance(threads, int) and threads >= 1):
            raise ValueError(f"threads must be a positive integer or None, got {threads!r}")
        self.n_links, self.fps, self.refine = n_links, float(fps), refine
        self.threads = threads
        self.reference_direction = reference_direction
        self.model = load_model(checkpoint or default_checkpoint(n_links))
        self.torque_model = TorqueModel(robot) if robot is not None else None
        self.reset()

    def reset(self) -> None:
        self.path = PathEstimator(self.n_links, self.fps)

    def update(self, frame: np.ndarray) -> Estimate:
        """Take the next (H, W, 3) uint8 RGB frame and return the estimate for it."""
        if not (isinstance(frame, np.ndarray) and frame.dtype == np.uint8 and frame.ndim == 3
                and frame.shape[2] == 3):
            got = (f"{frame.shape} {frame.dtype}" if isinstance(frame, np.ndarray)
                   else type(frame).__name__)
            raise ValueError(f"CNNEstimator takes (H, W, 3) uint8 RGB frames, got {got}")
        with torch_threads(self.threads):
            keypoints = predict_keypoints(self.model, [frame], refine=self.refine)[0]
        if not np.all(np.isfinite(keypoints)):
            keypoints = np.zeros((3, 2))  # a diverged network must not emit NaN
        angles = keypoints_to_angles(keypoints, self.n_links, self.reference_direction)
        self.path.update(angles)
        omega, alpha = self.path.omega(), self.path.alpha()
        torque = (self.torque_model(angles, omega, alpha) if self.torque_model is not None
                  else np.zeros(self.n_links))
        shown = keypoints[1:] if self.n_links == 1 else keypoints
        return Estimate(angles=angles, omega=omega, alpha=alpha, torque=torque, trust=1.0,
                        keypoints=shown)

    def run(self, frames: Iterable[np.ndarray]) -> list[Estimate]:
        """Estimates for every frame of an iterable."""
        self.reset()
        return [self.update(frame) for frame in frames]
