"""On-disk cache of rendered clips: a second use of the same `ClipSpec` costs no rendering.

One uncompressed ``.npz`` per spec, named by the spec's content hash, in
``$IMIMIC_CACHE_DIR`` (default ``$XDG_CACHE_HOME/imimic_gym/clips``, i.e.
``~/.cache/imimic_gym/clips``). Files are written to a temporary name and renamed, so a
reader never sees half a file, and parallel workers rendering the same clip do not clash.
A file that cannot be read whole (truncated, flipped bytes: the zip CRC catches them), was
written by another format version, or belongs to another spec is re-rendered.
"""

from __future__ import annotations

import json
import logging
import os
import tempfile
import zipfile
from pathlib import Path

import numpy as np

from imimic_gym.clips.scenarios import ClipSpec
from imimic_gym.clips.synthetic import render_clip
from imimic_gym.clips.types import Clip, ClipTruth, depth_from_mm, depth_to_mm

__all__ = ["cache_dir", "cache_path", "load_clip"]

FORMAT_VERSION = 2  # 2: depth stored as whole millimetres (uint16)
log = logging.getLogger(__name__)


def cache_dir() -> Path:
    if os.environ.get("IMIMIC_CACHE_DIR"):
        return Path(os.environ["IMIMIC_CACHE_DIR"])
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "imimic_gym" / "clips"


def cache_path(spec: ClipSpec) -> Path:
    return cache_dir() / f"{spec.key()}.npz"


def _write(path: Path, clip: Clip) -> None:
    truth = clip.truth
    assert truth is not None and clip.depth is not None
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=path.stem, suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as f:
            np.savez(
                f,
                format_version=np.int64(FORMAT_VERSION),
                meta=np.array(json.dumps(clip.meta)),
                fps=np.float64(clip.fps),
                frames=clip.frames,
                depth_mm=depth_to_mm(clip.depth),
                angles=truth.angles,
                angular_velocity=truth.angular_velocity,
                angular_acceleration=truth.angular_acceleration,
                keypoints=truth.keypoints,
                visible=truth.visible,
                occlusion=truth.occlusion,
                keypoint_names=np.array(truth.keypoint_names),
            )
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def _read(path: Path, spec: ClipSpec) -> Clip:
    with np.load(path, allow_pickle=False) as z:
        if int(z["format_version"]) != FORMAT_VERSION:
            raise ValueError(f"format version {int(z['format_version'])}, want {FORMAT_VERSION}")
        meta = json.loads(str(z["meta"]))
        if meta.get("spec_key") != spec.key():
            raise ValueError(f"holds clip {meta.get('spec_key')}, want {spec.key()}")
        truth = ClipTruth(
            angles=z["angles"],
            angular_velocity=z["angular_velocity"],
            angular_acceleration=z["angular_acceleration"],
            keypoints=z["keypoints"],
            visible=z["visible"],
            occlusion=z["occlusion"],
            keypoint_names=tuple(str(n) for n in z["keypoint_names"]),
        )
        meta["scenario"] = spec.name
        return Clip(frames=z["frames"], fps=float(z["fps"]), depth=depth_from_mm(z["depth_mm"]),
                    truth=truth, meta=meta)


def load_clip(spec: ClipSpec, progress: bool = True, use_cache: bool = True) -> Clip:
    """The clip for ``spec``: from the cache if a sound copy is there, else rendered (and
    cached). ``progress`` shows a progress bar while rendering."""
    path = cache_path(spec)
    if use_cache and path.exists():
        try:
            return _read(path, spec)
        except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile) as err:
            log.warning("cached clip %s is unusable (%s); rendering it again", path, err)
    clip = render_clip(spec, progress=progress)
    if use_cache:
        _write(path, clip)
    return clip
