"""On-disk cache of rendered clips: a second use of the same `ClipSpec` costs no rendering.

One uncompressed ``.npz`` per spec, named by the spec's content hash and the renderer's
(`renderer_fingerprint`: two checkouts or installs that draw a clip differently never
read each other's), in
``$IMIMIC_CACHE_DIR`` (default ``$XDG_CACHE_HOME/imimic_gym/clips``, i.e.
``~/.cache/imimic_gym/clips``). Files are written to a temporary name and renamed, so a
reader never sees half a file, and parallel workers rendering the same clip do not clash.
A file that cannot be read whole (truncated, flipped bytes: the zip CRC catches them), was
written by another format version, or belongs to another spec is re-rendered.

The cache is bounded: after each clip it writes, the clips least recently used (written or
read) are deleted until the clips left take at most ``$IMIMIC_CACHE_MAX_GB`` (default
`DEFAULT_MAX_GB`; ``inf`` for no bound). A 150-frame 240x320 clip with its depth is about
58 MB, so the default keeps about 340 of them; a working set larger than the bound (the
benchmarks' hundreds of development clips) is rendered again on every pass. Deleting a
clip another process is reading is safe (POSIX keeps the open file), and one deleted
between the check and the read is rendered again like a damaged one.
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import importlib.util
import json
import logging
import math
import os
import zipfile
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from imimic_gym.atomic import atomic_write
from imimic_gym.clips.scenarios import ClipSpec
from imimic_gym.clips.synthetic import render_clip
from imimic_gym.clips.types import Clip, ClipTruth, depth_from_mm, depth_to_mm

__all__ = ["CacheSettingError", "CacheUsage", "cache_dir", "cache_limit_bytes", "cache_path",
           "cache_usage", "check_warmed", "clear_cache", "load_clip", "pose_labels_dir",
           "prune_cache", "renderer_fingerprint", "warm_clip"]

FORMAT_VERSION = 2  # 2: depth stored as whole millimetres (uint16)
DEFAULT_MAX_GB = 20.0
log = logging.getLogger(__name__)


def cache_dir() -> Path:
    if os.environ.get("IMIMIC_CACHE_DIR"):
        return Path(os.environ["IMIMIC_CACHE_DIR"])
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "imimic_gym" / "clips"


def pose_labels_dir() -> Path:
    """The cache's folder of the pose model's labels of videos (`labels.video_labels`)."""
    return cache_dir() / "pose-labels"


# The modules whose code decides a rendered clip's pixels and truth.
RENDERER_MODULES = ("imimic_gym.clips.synthetic", "imimic_gym.clips.demonstrator",
                    "imimic_gym.clips.gestures", "imimic_gym.clips.motion",
                    "imimic_gym.clips.scenarios", "imimic_gym.clips.types",
                    "imimic_gym.kinematics", "imimic_gym.render", "imimic_gym.robots.planar",
                    "imimic_gym.spatial.camera")


@functools.cache
def renderer_fingerprint() -> str:
    """8 hex digits of a hash of `RENDERER_MODULES`' source and MuJoCo's version: what
    draws a clip, beside the `ClipSpec` that says what to draw."""
    import mujoco

    digest = hashlib.sha256(mujoco.__version__.encode())
    for name in RENDERER_MODULES:
        found = importlib.util.find_spec(name)
        assert found is not None and found.origin is not None, name
        digest.update(Path(found.origin).read_bytes())
    return digest.hexdigest()[:8]


def cache_path(spec: ClipSpec) -> Path:
    return cache_dir() / f"{spec.key()}-{renderer_fingerprint()}.npz"


class CacheSettingError(ValueError):
    """An environment variable that sets up the clip cache has a value it cannot use."""


def cache_limit_bytes() -> float:
    """The bound on the clips' total size, bytes, from ``$IMIMIC_CACHE_MAX_GB`` (GB of
    10^9 bytes; ``inf`` for none), `DEFAULT_MAX_GB` if unset."""
    raw = os.environ.get("IMIMIC_CACHE_MAX_GB", "").strip()
    if not raw:
        return DEFAULT_MAX_GB * 1e9
    try:
        gb = float(raw)
    except ValueError:
        gb = math.nan
    if not gb > 0:  # also NaN
        raise CacheSettingError(f"IMIMIC_CACHE_MAX_GB must be a positive number of GB or "
                                f"'inf', got {raw!r}")
    return gb * 1e9


class CacheUsage(NamedTuple):
    """What the clip cache holds: its folder, how many clips, their total bytes."""

    directory: Path
    clips: int
    bytes: int


def _clips() -> list[tuple[float, int, Path]]:
    """(last use, size in bytes, path) of every cached clip, least recently used first."""
    found = []
    for path in cache_dir().glob("*.npz"):
        try:
            stat = path.stat()
        except FileNotFoundError:  # deleted by another process meanwhile
            continue
        found.append((stat.st_mtime, stat.st_size, path))
    return sorted(found)


def cache_usage() -> CacheUsage:
    clips = _clips()
    return CacheUsage(cache_dir(), len(clips), sum(size for _, size, _ in clips))


def prune_cache(limit_bytes: float, keep: Path | None = None) -> int:
    """Delete the least recently used clips until the rest take at most ``limit_bytes``
    (never ``keep``, the clip just written). Returns how many were deleted."""
    clips = _clips()
    total = sum(size for _, size, _ in clips)
    deleted = 0
    for _, size, path in clips:
        if total <= limit_bytes:
            break
        if path == keep:
            continue
        path.unlink(missing_ok=True)
        total -= size
        deleted += 1
    if deleted:
        log.info("clip cache over %.1f GB: deleted the %d least recently used clips from %s",
                 limit_bytes / 1e9, deleted, cache_dir())
    return deleted


def clear_cache() -> int:
    """Delete every cached clip, and the pose model's labels of videos kept beside them
    (`pose_labels_dir`); the rendered dataset images are kept.
    Returns how many clips were deleted."""
    for labels in pose_labels_dir().glob("*.npz"):
        labels.unlink(missing_ok=True)
    return prune_cache(0.0)


def _write(path: Path, clip: Clip) -> None:
    truth = clip.truth
    assert truth is not None and clip.depth is not None
    spatial: dict[str, Any] = {}
    if truth.points3d is not None:
        assert truth.points2d is not None and truth.arm_angles is not None
        spatial = {"points3d": truth.points3d, "points2d": truth.points2d,
                   "arm_angles": truth.arm_angles}
    with atomic_write(path) as f:
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
            **spatial,
        )


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
            **({name: z[name] for name in ("points3d", "points2d", "arm_angles")}
               if "points3d" in z else {}),
        )
        meta["scenario"] = spec.name
        return Clip(frames=z["frames"], fps=float(z["fps"]), depth=depth_from_mm(z["depth_mm"]),
                    truth=truth, meta=meta)


_IMPORTED_IN = os.getpid()  # a process that forked after importing us has another pid


def _render_in_spawned_process(spec: ClipSpec, progress: bool) -> None:
    """Render ``spec`` into the cache from a new interpreter (not a fork; a subprocess,
    since vector-env workers are daemons that multiprocessing forbids children)."""
    import pickle
    import subprocess
    import sys

    code = ("import pickle, sys; from imimic_gym.clips.cache import load_clip; "
            "spec, progress = pickle.load(sys.stdin.buffer); load_clip(spec, progress)")
    done = subprocess.run([sys.executable, "-c", code], input=pickle.dumps((spec, progress)),
                          check=False)
    if done.returncode != 0:
        raise RuntimeError(f"rendering clip {spec.name!r} seed {spec.seed} in a new process "
                           f"failed (exit code {done.returncode}); its output above says why")


def load_clip(spec: ClipSpec, progress: bool = True, use_cache: bool = True) -> Clip:
    """The clip for ``spec``: from the cache if a sound copy is there, else rendered (and
    cached, then the cache pruned to its bound). ``progress`` shows a progress bar while
    rendering."""
    path = cache_path(spec)
    if use_cache and path.exists():
        try:
            clip = _read(path, spec)
        except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile) as err:
            log.warning("cached clip %s is unusable (%s); rendering it again", path, err)
        else:
            with contextlib.suppress(OSError):  # a read-only cache is still read
                os.utime(path)  # its last use, for pruning
            return clip
    limit = cache_limit_bytes() if use_cache else None  # a bad setting fails before rendering
    if limit is not None and os.getpid() != _IMPORTED_IN:
        # A forked child (gym.make_vec's async workers fork on Linux) hangs in EGL when it
        # renders: render in a freshly spawned process instead, and read the cache.
        _render_in_spawned_process(spec, progress)
        with contextlib.suppress(OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile):
            return _read(path, spec)
    clip = render_clip(spec, progress=progress)
    if limit is not None:
        _write(path, clip)
        prune_cache(limit, keep=path)
    return clip


def warm_clip(spec: ClipSpec) -> dict[str, Any]:
    """Make sure ``spec``'s clip is in this process's cache (rendered if missing or
    unusable), read it back whole, and say where it is: ``{"key", "path", "bytes",
    "sha256", "host"}``. Run on a cluster's workers (`backends.fan_out`), each fills the
    cache of its node, or the shared folder ``IMIMIC_CACHE_DIR`` names."""
    from imimic_gym.checkpoints import file_sha256

    load_clip(spec, progress=False)
    path = cache_path(spec)
    _read(path, spec)
    return {"key": spec.key(), "path": str(path), "bytes": path.stat().st_size,
            "sha256": file_sha256(path), "host": os.uname().nodename}


def check_warmed(spec: ClipSpec, warmed: dict[str, Any]) -> bool:
    """Check what `warm_clip` reported, where this process can see the file: the same
    bytes, read back whole as ``spec``'s clip. False where the file is not visible here
    (another node's own cache); raises `ValueError` naming the file if it is not sound."""
    from imimic_gym.checkpoints import file_sha256

    path = Path(warmed["path"])
    if not path.is_file():
        return False
    try:
        _read(path, spec)
        sound = file_sha256(path) == warmed["sha256"]
    except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile) as error:
        raise ValueError(f"cached clip {path} ({spec.name} seed {spec.seed}) does not read "
                         f"back: {error}") from error
    if not sound:
        raise ValueError(f"cached clip {path} ({spec.name} seed {spec.seed}) differs from "
                         "what its worker wrote")
    return True
