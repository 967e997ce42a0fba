"""The labelled-arm dataset of rendered demonstrator images, and loading any labelled set.

The shipped dataset (``annotations/arm{1,2}_{train,test}.json``) holds no pixels: each
image records the `ClipSpec` (seed included) and the frame index it was rendered from
(``imimic_render``), and the SHA-256 of its RGB bytes. The renderer is deterministic,
so `load_images` regenerates the images bit for bit on first use and caches them as PNG
(lossless) under ``<clip cache>/dataset_images``, named by spec and frame. A cached file
whose hash no longer matches is rendered again.

The paper's dataset is 300 images, 224 for training and 76 for testing. Ours: per
number of links, clips of varied background, lighting, camera distance, body sway and
random (spline) motion, four frames from each, and the split made by clip (56 train
clips, 19 test clips), so no test pose is a neighbouring frame of a training one.
"""

from __future__ import annotations

import hashlib
import logging
from collections import defaultdict
from pathlib import Path
from typing import Any, cast

import cv2
import numpy as np
from tqdm.auto import tqdm

from imimic_gym.atomic import write_bytes
from imimic_gym.checkpoints import SHIPPED_ANNOTATIONS
from imimic_gym.clips.annotations import ArmAnnotation, image_path
from imimic_gym.clips.cache import cache_dir, renderer_fingerprint
from imimic_gym.clips.demonstrator import camera_pose, workspace
from imimic_gym.clips.scenarios import SKIN_TONES, Appearance, Background, ClipSpec
from imimic_gym.clips.synthetic import render_clip

__all__ = ["DEFAULT_ANNOTATIONS", "IMAGES_PER_CLIP", "arm_in_frame", "generate_arms",
           "load_images", "randomised_spec", "rendered_image_path"]

DEFAULT_ANNOTATIONS = SHIPPED_ANNOTATIONS
IMAGES_PER_CLIP = 4
CLIP_FRAMES = 60  # 2 s of spline motion: four frames from it are four different poses
log = logging.getLogger(__name__)


def _sample_spec(links: int, seed: int, rng: np.random.Generator) -> ClipSpec:
    """A clip with random background, lighting, distance and sway (all within the range
    the env's scenarios use)."""
    return ClipSpec(
        n_links=links, motion="spline", seed=seed, n_frames=CLIP_FRAMES,
        background=cast(Background, str(rng.choice(["plain", "textured", "cluttered"]))),
        lighting=round(float(rng.uniform(0.5, 1.0)), 3),
        camera_distance=round(float(rng.uniform(1.9, 2.6)), 3),
        sway=round(float(rng.uniform(0.0, 1.0)), 3),
    )


# Skin tones from light to dark (linear RGB); a drawn tone is one of them, jittered.


def arm_in_frame(spec: ClipSpec, margin: float = 4.0) -> bool:
    """Does the whole region the arm can sweep (`workspace`, a disc in the arm's plane)
    project inside the frame, ``margin`` pixels from its edges, for a person's scene?"""
    centre, radius = workspace(spec)
    position, right, up, fovy = camera_pose(spec)
    forward = np.cross(up, right)  # the camera looks along -(right x up)
    turn = np.linspace(0, 2 * np.pi, 24, endpoint=False)
    rim = centre + radius * np.stack([np.cos(turn), np.zeros_like(turn), np.sin(turn)], 1)
    local = rim - position
    depth = local @ forward
    if np.any(depth <= 0.1):
        return False
    focal = 0.5 * spec.height / np.tan(np.radians(fovy) / 2)
    x = spec.width / 2 + focal * (local @ right) / depth
    y = spec.height / 2 - focal * (local @ up) / depth
    return bool(np.all((x >= margin) & (x <= spec.width - 1 - margin)
                       & (y >= margin) & (y <= spec.height - 1 - margin)))


def randomised_spec(links: int, seed: int, rng: np.random.Generator) -> ClipSpec:
    """A clip of a person with everything ``rng`` can vary drawn at random (domain
    randomisation): clothing and skin colours, long or short sleeves, a plain, tiled or
    cluttered backdrop of any colour and tile size, the light's strength, direction and
    colour, the camera's distance (the person's scale), height, tilt, sideways place and
    field of view (the person's place in the frame), and body sway. Drawn again until the
    arm's whole workspace is in the frame (`arm_in_frame`)."""

    def rgb(values: np.ndarray) -> tuple[float, float, float]:
        r, g, b = (round(float(v), 3) for v in values)
        return r, g, b

    def colour(low: float, high: float) -> tuple[float, float, float]:
        return rgb(rng.uniform(low, high, 3))

    def number(low: float, high: float) -> float:
        return round(float(rng.uniform(low, high)), 3)

    while True:
        tone = np.array(SKIN_TONES[rng.integers(len(SKIN_TONES))])
        skin = rgb(np.clip(tone + rng.uniform(-0.04, 0.04, 3), 0, 1))
        distance, height = number(1.7, 3.6), number(-0.5, 0.8)
        appearance = Appearance(
            skin=skin, shirt=colour(0.03, 0.97), pants=colour(0.03, 0.8),
            long_sleeves=bool(rng.random() < 0.5), wall=colour(0.08, 0.97),
            tile=colour(0.08, 0.97), floor=colour(0.08, 0.7), tile_size=number(0.08, 0.6),
            clutter=int(rng.integers(4, 31)),
            light_direction=(number(-1, 1), number(0.3, 1), number(-1, -0.2)),
            light_colour=colour(0.75, 1.0), camera_height=height,
            camera_tilt=round(float(np.degrees(np.arctan2(height, distance))
                                    + rng.uniform(-8, 8)), 3),
            camera_shift=number(-0.7, 0.7), fovy=number(35, 60),
        )
        spec = ClipSpec(
            n_links=links, motion="spline", seed=seed, n_frames=CLIP_FRAMES,
            background=cast(Background, str(rng.choice(["plain", "textured", "cluttered"],
                                                        p=[0.2, 0.4, 0.4]))),
            lighting=number(0.4, 1.0), camera_distance=distance, sway=number(0.0, 1.0),
            appearance=appearance,
        )
        if arm_in_frame(spec):
            return spec


def _digest(image: np.ndarray) -> str:
    return hashlib.sha256(np.ascontiguousarray(image).tobytes()).hexdigest()


def rendered_image_path(render: dict) -> Path:
    """Cache file of a rendered image:
    ``<clip cache>/dataset_images/<spec key>-<renderer_fingerprint>_f<k>.png``."""
    spec = ClipSpec(**render["spec"])
    return (cache_dir() / "dataset_images"
            / f"{spec.key()}-{renderer_fingerprint()}_f{render['frame_index']:03d}.png")


def _store(path: Path, rgb: np.ndarray) -> None:
    """Write a PNG whole (`atomic.write_bytes`): a reader never sees half a file."""
    ok, png = cv2.imencode(".png", cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR))
    if not ok:
        raise OSError(f"could not encode {path}")
    write_bytes(path, png.tobytes())


def generate_arms(links: int, n_clips: int, first_seed: int, rng_seed: int,
                  prefix: str, progress: bool = True, backend: str = "local",
                  address: str | None = None, randomise: bool = False) -> list[ArmAnnotation]:
    """Render ``n_clips`` random clips of a ``links``-link demonstrator (seeds from
    ``first_seed``) and label ``IMAGES_PER_CLIP`` distinct frames of each with the true
    shoulder, elbow and wrist; the images go into the cache. ``rng_seed`` draws the
    clips' settings and frames. File names are ``<prefix>/c<seed>_f<frame>.png``.
    ``randomise`` draws each clip's whole look too (`randomised_spec`); without it the
    clips vary only as the env's scenarios do (the shipped dataset).

    The clips render here or as Ray tasks (``backend``, ``address``: `backends.fan_out`);
    the images come back to this process, are checked against their workers' hashes and
    stored here, so the dataset is the same either way."""
    from imimic_gym.backends import fan_out

    rng = np.random.default_rng(rng_seed)
    jobs = []
    sample = randomised_spec if randomise else _sample_spec
    for seed in range(first_seed, first_seed + n_clips):
        spec = sample(links, seed, rng)
        jobs.append((spec, tuple(np.sort(rng.choice(CLIP_FRAMES, IMAGES_PER_CLIP,
                                                    replace=False)).tolist())))
    rendered = {}
    for outcome in tqdm(fan_out(_render_labelled, jobs, backend=backend, address=address),
                        total=len(jobs), desc=f"rendering {prefix} ({backend})",
                        disable=not progress, unit="clip"):
        spec = outcome.item[0]
        if not outcome.ok:
            raise RuntimeError(f"rendering dataset clip seed {spec.seed} failed after "
                               f"{outcome.attempts} attempts: {outcome.error}")
        rendered[spec.seed] = outcome.value
    arms: list[ArmAnnotation] = []
    for spec, frames in jobs:
        images, keypoints, digests = rendered[spec.seed]
        fields = spec.record()
        for k, image, points, digest in zip(frames, images, keypoints, digests, strict=True):
            render = {"spec": fields, "frame_index": k, "sha256": _digest(image)}
            if render["sha256"] != digest:
                raise RuntimeError(f"dataset clip seed {spec.seed} frame {k} changed on its "
                                   "way back from the worker")
            _store(rendered_image_path(render), image)
            arms.append(ArmAnnotation(
                file_name=f"{prefix}/c{spec.seed}_f{k:03d}.png", width=spec.width,
                height=spec.height, keypoints=points, labelled=np.ones(3, dtype=bool),
                image_id=len(arms) + 1, render=render))
    return arms


def _render_labelled(job: tuple[ClipSpec, tuple[int, ...]],
                     ) -> tuple[list[np.ndarray], list[np.ndarray], list[str]]:
    """One dataset clip's chosen frames (H, W, 3) uint8 RGB, their shoulder, elbow and
    wrist (3, 2) px, and the frames' hashes."""
    spec, frames = job
    clip = render_clip(spec, progress=False)
    assert clip.truth is not None
    names = clip.truth.keypoint_names
    index = [names.index(n) for n in ("shoulder", "elbow", "wrist")]
    images = [clip.frames[k].copy() for k in frames]
    return (images, [clip.truth.keypoints[k, index].copy() for k in frames],
            [_digest(image) for image in images])


def _read_rgb(path: Path) -> np.ndarray | None:
    bgr = cv2.imread(str(path), cv2.IMREAD_COLOR)
    return None if bgr is None else cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB)


def _regenerate(records: list[dict[str, Any]], progress: bool) -> None:
    """Render the clips of the rendered images (their ``render`` records) missing from
    the cache, each clip once."""
    missing: dict[str, list[dict]] = defaultdict(list)
    specs: dict[str, ClipSpec] = {}
    for record in records:
        path = rendered_image_path(record)
        cached = _read_rgb(path) if path.is_file() else None
        if cached is None or _digest(cached) != record.get("sha256", _digest(cached)):
            spec = ClipSpec(**record["spec"])
            specs[spec.key()] = spec
            missing[spec.key()].append(record)
    for key in tqdm(missing, desc="regenerating dataset images",
                    disable=not (progress and missing), unit="clip"):
        renders = missing[key]
        last = max(r["frame_index"] for r in renders)
        clip = render_clip(specs[key].replace(n_frames=max(last + 1, specs[key].n_frames)),
                           progress=False)
        for render in renders:
            image = clip.frames[render["frame_index"]]
            if render.get("sha256") and _digest(image) != render["sha256"]:
                log.warning("regenerated %s differs from the recorded image (another "
                            "renderer build?); using it anyway", rendered_image_path(render))
            _store(rendered_image_path(render), image)


def load_images(arms: list[ArmAnnotation], images_dir: str | Path | None = None,
                progress: bool = True) -> list[np.ndarray]:
    """The images of ``arms``, each (H, W, 3) uint8 RGB.

    Rendered images (``render`` set) come from the cache, regenerated when missing;
    others are read from ``images_dir`` (their ``file_name`` is relative to it).

    Raises:
        ValueError: a photo's annotation but no ``images_dir``.
        FileNotFoundError: an image file is missing (the message names the path).
        OSError: an image file cannot be decoded.
    """
    rendered = [a.render for a in arms if a.render is not None]
    if rendered and images_dir is None:
        _regenerate(rendered, progress)
    images = []
    for arm in arms:
        if arm.render is not None and images_dir is None:
            path = rendered_image_path(arm.render)
        elif images_dir is None:
            raise ValueError(f"image {arm.file_name!r} is a photo, not a rendered image: "
                             "pass the folder that holds it (--images)")
        else:
            path = image_path(arm, images_dir)
        rgb = _read_rgb(path)
        if rgb is None:
            raise OSError(f"image {path} could not be decoded")
        if rgb.shape[:2] != (arm.height, arm.width):
            raise ValueError(f"image {path} is {rgb.shape[1]}x{rgb.shape[0]}, but its "
                             f"annotation says {arm.width}x{arm.height}")
        images.append(rgb)
    return images
