"""The checks `ImitateVideoEnv` makes of its arguments before building anything: each
wrong one is a ValueError naming the argument, what it got and what it takes."""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from imimic_gym.clips.types import MODALITIES, Clip
from imimic_gym.robots.planar import CONTROL_MODES, MAX_LINKS

__all__ = ["MAX_SIDE", "check_arguments", "check_sources"]

MAX_SIDE = 4096  # px: frames and renders (MuJoCo's offscreen buffer fails far past this)


def check_arguments(control: str, modality: str, render_mode: str | None,
                    render_modes: Sequence[str], **numbers: Any) -> None:
    """``control``, ``modality`` and ``render_mode`` among the allowed; ``width``,
    ``height``, ``render_height`` (px), ``n_frames`` and ``n_links`` whole numbers in
    range or None; ``tracking_weight``, ``ctrl_cost_weight`` and ``reset_noise_scale``
    finite numbers >= 0."""
    if control not in CONTROL_MODES:
        raise ValueError(f"control must be one of {CONTROL_MODES}, got {control!r}")
    if modality not in MODALITIES:
        raise ValueError(f"modality must be one of {MODALITIES}, got {modality!r}")
    if render_mode not in (None, *render_modes):
        raise ValueError(f"render_mode must be None or 'rgb_array', got {render_mode!r}")
    for name, low, high in (("width", 1, MAX_SIDE), ("height", 1, MAX_SIDE),
                            ("render_height", 1, MAX_SIDE), ("n_frames", 2, None),
                            ("n_links", 1, MAX_LINKS)):
        value = numbers[name]
        whole = isinstance(value, (int, np.integer)) and not isinstance(value, bool)
        if value is not None and not (whole and low <= value <= (high or value)):
            span = f"from {low} to {high}" if high else f"of at least {low}"
            raise ValueError(f"{name} must be an integer {span}, got {value!r}")
    for name in ("tracking_weight", "ctrl_cost_weight", "reset_noise_scale"):
        weight = numbers[name]
        if not (isinstance(weight, (int, float, np.number)) and math.isfinite(weight)
                and weight >= 0):
            raise ValueError(f"{name} must be a finite number >= 0, got {weight!r}")


def check_sources(clip: Any, annotations: Any, clip_seeds: Any) -> None:
    """``clip`` None, a video path or a `Clip`; ``annotations`` None, "pose" or the path of
    a labels file (not a folder); ``clip_seeds`` a sequence of whole numbers."""
    if clip is not None and not isinstance(clip, (str, Path, Clip)):
        raise ValueError(f"clip must be a video file's path or a Clip, got {clip!r}")
    if annotations is not None:
        if not isinstance(annotations, (str, Path)):
            raise ValueError(f"annotations must be 'pose' or the path of a labels file "
                             f"(COCO-keypoints JSON), got {annotations!r}")
        if annotations != "pose" and Path(annotations).is_dir():
            raise ValueError(f"annotations must be 'pose' or the path of a labels file "
                             f"(COCO-keypoints JSON), got the folder {str(annotations)!r}")
    whole = (isinstance(clip_seeds, (Sequence, np.ndarray))
             and not isinstance(clip_seeds, (str, bytes))
             and all(isinstance(seed, (int, np.integer)) and not isinstance(seed, bool)
                     for seed in clip_seeds))
    if not whole:
        raise ValueError(f"clip_seeds must be a sequence of whole numbers (clip seeds, such "
                         f"as (0, 1)), got {clip_seeds!r}")
