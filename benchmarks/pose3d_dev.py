"""Development only: the 3-D pose estimators on a video without truth, or the lift on
synthetic arms with truth (for choosing its settings; `docs/decisions/pose3d-lift.md`).

    python benchmarks/pose3d_dev.py --video ../shared/realdata/dev/dev04_*.mp4 --png out.png
    python benchmarks/pose3d_dev.py --synthetic

On a video, the pose model runs once per frame and its readings are replayed into
``pose3d`` (the lift) and ``pose-world`` (MediaPipe's world landmarks); printed per
estimator:
- coverage: the share of frames with a reading (trust > 0);
- smoothness: the median change of the forearm's 3-D direction between consecutive
  frames with readings, degrees;
- flips: frame pairs where a bone's (upper arm's or forearm's) depth extent changes sign
  while staying over `FLIP_EXTENT` of its length in both frames (it did not pass through
  the image plane, where its 2-D length is long, so the turn is the lift's, not the arm's);
- elbow flexion: median and 5th-95th percentiles, degrees.
``--png`` draws a few frames with the lifted arm reprojected and two insets, a side view
(z right, y down) and a top view (x right, z down), pose3d green, pose-world orange.

Develop and choose settings ONLY on ../shared/realdata/dev/ clips and synthetic arms;
never on the evaluation footage.
"""

from __future__ import annotations

import argparse
import itertools
import math
import sys
from pathlib import Path
from typing import Any, cast

import cv2
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from imimic_gym.estimators.pose.model import BodyKeypoints, PoseModel
from imimic_gym.estimators.pose.spatial import Pose3DEstimator
from imimic_gym.spatial import ArmPose, Intrinsics, angle_between
from imimic_gym.spatial.lift import BoneLengths
from imimic_gym.spatial.smoothing import OneEuroSettings

Settings = list[dict[str, Any]]

FLIP_EXTENT = 0.3
GREEN, ORANGE, WHITE = (40, 200, 40), (255, 140, 0), (255, 255, 255)


class Replay:
    """A pose model that plays back recorded readings (the estimators' `model`)."""

    def __init__(self, bodies: list[BodyKeypoints | None]) -> None:
        self.bodies, self.i = bodies, 0

    def reset(self) -> None:
        self.i = 0

    def __call__(self, frame: np.ndarray, time_s: float | None = None
                 ) -> BodyKeypoints | None:
        body = self.bodies[self.i]
        self.i += 1
        return body


def read_video(path: str, max_frames: int | None) -> tuple[list[np.ndarray], float]:
    capture = cv2.VideoCapture(path)
    if not capture.isOpened():
        raise SystemExit(f"cannot open {path}")
    fps = capture.get(cv2.CAP_PROP_FPS) or 30.0
    frames: list[np.ndarray] = []
    while max_frames is None or len(frames) < max_frames:
        ok, frame = capture.read()
        if not ok:
            break
        frames.append(cv2.cvtColor(frame, cv2.COLOR_BGR2RGB))
    capture.release()
    return frames, float(fps)


def summary(poses: list[ArmPose]) -> dict[str, float]:
    seen = [p.trust > 0 for p in poses]
    turns, flips = [], 0
    for a, b, sa, sb in zip(poses, poses[1:], seen, seen[1:], strict=False):
        if not (sa and sb) or a.side != b.side:
            continue
        turns.append(math.degrees(angle_between(a.forearm, b.forearm)))
        for start, end in ((0, 1), (1, 2)):
            extents = []
            for pose in (a, b):
                bone = pose.points[end] - pose.points[start]
                extents.append(bone[2] / max(float(np.linalg.norm(bone)), 1e-9))
            if min(abs(e) for e in extents) > FLIP_EXTENT and extents[0] * extents[1] < 0:
                flips += 1
    flexion = [math.degrees(p.elbow_flexion) for p, s in zip(poses, seen, strict=True) if s]
    low, mid, high = np.percentile(flexion, [5, 50, 95]) if flexion else (math.nan,) * 3
    return {"coverage": float(np.mean(seen)),
            "smoothness_deg": float(np.median(turns)) if turns else math.nan,
            "flips": float(flips), "flexion_p5": low, "flexion_median": mid,
            "flexion_p95": high}


def inset(poses: dict[str, ArmPose], axes: tuple[int, int], size: int) -> np.ndarray:
    """A (size, size, 3) view of the arms on two camera axes, the shoulder in the middle,
    1.6 m across."""
    view = np.full((size, size, 3), 30, np.uint8)
    half = size / 2
    scale = size / 1.6
    cv2.line(view, (int(half), 0), (int(half), size), (70, 70, 70), 1)
    cv2.line(view, (0, int(half)), (size, int(half)), (70, 70, 70), 1)
    for colour, pose in zip((GREEN, ORANGE), poses.values(), strict=False):
        origin = pose.points[0]
        offsets = (pose.points[:4] - origin)[:, list(axes)]
        xy = [(int(half + scale * u), int(half + scale * v)) for u, v in offsets]
        for a, b in itertools.pairwise(xy):
            cv2.line(view, a, b, colour, 2, cv2.LINE_AA)
        cv2.circle(view, xy[1], 4, colour, -1)
    return view


def picture(frames: list[np.ndarray], runs: dict[str, list[ArmPose]],
            camera: Intrinsics, path: str, title: str, count: int = 4) -> None:
    lift = runs["pose3d"]
    seen = [i for i, p in enumerate(lift) if p.trust > 0]
    if not seen:
        print("no frame with a reading: no picture")
        return
    chosen = [seen[round(k)] for k in np.linspace(0, len(seen) - 1, count)]
    tiles = []
    for i in chosen:
        frame = frames[i].copy()
        height = 480
        scale = height / frame.shape[0]
        image = cv2.resize(frame, (round(frame.shape[1] * scale), height),
                           interpolation=cv2.INTER_AREA)
        for colour, name in ((ORANGE, "pose-world"), (GREEN, "pose3d")):
            points = camera.project(runs[name][i].points[:4]) * scale
            for a, b in itertools.pairwise(points):
                cv2.line(image, tuple(map(int, a)), tuple(map(int, b)), colour, 2, cv2.LINE_AA)
        views = [inset({n: runs[n][i] for n in ("pose3d", "pose-world")}, axes, 200)
                 for axes in ((2, 1), (0, 2))]
        panel = np.full((height, 204, 3), 0, np.uint8)
        panel[:200, 2:202], panel[220:420, 2:202] = views
        cv2.putText(panel, "side: z right, y down", (4, 214), cv2.FONT_HERSHEY_SIMPLEX, 0.4,
                    WHITE, 1)
        cv2.putText(panel, "top: x right, z down", (4, 434), cv2.FONT_HERSHEY_SIMPLEX, 0.4,
                    WHITE, 1)
        image = np.concatenate([image, panel], axis=1)
        text = (f"f{i} flex {math.degrees(lift[i].elbow_flexion):.0f} "
                f"(world {math.degrees(runs['pose-world'][i].elbow_flexion):.0f})")
        cv2.rectangle(image, (0, height - 32), (300, height), (0, 0, 0), -1)
        cv2.putText(image, text, (5, height - 10), cv2.FONT_HERSHEY_SIMPLEX, 0.6, WHITE, 2)
        tiles.append(image)
    width = max(t.shape[1] for t in tiles)
    tiles = [np.pad(t, ((0, 0), (0, width - t.shape[1]), (0, 0))) for t in tiles]
    sheet = np.concatenate([np.concatenate(tiles[:2], 1), np.concatenate(tiles[2:4], 1)], 0)
    cv2.rectangle(sheet, (0, 0), (8 * len(title) + 10, 28), (0, 0, 0), -1)
    cv2.putText(sheet, title, (5, 20), cv2.FONT_HERSHEY_SIMPLEX, 0.5, WHITE, 1, cv2.LINE_AA)
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    cv2.imwrite(path, cv2.cvtColor(sheet, cv2.COLOR_RGB2BGR))
    print(f"wrote {path}")


def run_video(path: str, max_frames: int | None, png: str | None,
              min_confidence: float, settings: Settings) -> None:
    frames, fps = read_video(path, max_frames)
    model = PoseModel(video=True)
    bodies = [model(frame, i / fps) for i, frame in enumerate(frames)]
    h, w = frames[0].shape[:2]
    camera = Intrinsics.guess(w, h)
    print(f"{Path(path).name}: {len(frames)} frames {w}x{h} at {fps:g} fps; the model "
          f"sees a person in {np.mean([b is not None for b in bodies]):.0%}")
    runs: dict[str, list[ArmPose]] = {}
    for name, source in (("pose3d", "lift"), ("pose-world", "world")):
        for setting in settings if name == "pose3d" else settings[:1]:
            estimator = Pose3DEstimator(fps, source=source, model=cast(PoseModel, Replay(bodies)),
                                        min_confidence=min_confidence, lift=setting)
            poses = [estimator.update(frame) for frame in frames]
            label = name if len(settings) == 1 or name != "pose3d" else f"{name} {setting}"
            print(f"  {label}: " + ", ".join(f"{k} {v:.3g}" for k, v in summary(poses).items()))
            runs.setdefault(name, poses)
    if png:
        picture(frames, runs, camera, png, f"{Path(path).name}: pose3d green, pose-world orange")


# Synthetic arms ---------------------------------------------------------------------

def _rotation(axis: np.ndarray, angle: float) -> np.ndarray:
    axis = axis / np.linalg.norm(axis)
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + math.sin(angle) * k + (1 - math.cos(angle)) * k @ k


def synthetic_clip(rng: np.random.Generator, frames: int, fps: float,
                   lengths: BoneLengths, side: str = "left") -> np.ndarray:
    """(T, 7, 3) camera-frame points of a person 1.8-3.5 m away, facing the camera (turned
    up to 25 degrees), moving their arm smoothly through human ranges: the upper arm's
    elevation, its azimuth (forward and out), the elbow's flexion and the forearm's twist
    as sums of slow sinusoids."""
    t = np.arange(frames) / fps
    depth, yaw = rng.uniform(1.8, 3.5), math.radians(rng.uniform(-25, 25))

    def wave(low: float, high: float) -> np.ndarray:
        f1, f2 = rng.uniform(0.1, 0.5, 2)
        p1, p2 = rng.uniform(0, 2 * math.pi, 2)
        s = 0.6 * np.sin(2 * math.pi * f1 * t + p1) + 0.4 * np.sin(2 * math.pi * f2 * t + p2)
        return low + (high - low) * (s + 1) / 2

    elevation = wave(math.radians(5), math.radians(110))   # from hanging down
    azimuth = wave(math.radians(-10), math.radians(100))   # 0: sideways out, 90: forward
    flexion = wave(0.0, math.radians(145))
    twist = wave(math.radians(-60), math.radians(60))
    out = 1.0 if side == "left" else -1.0
    turn = _rotation(np.array([0.0, 1.0, 0.0]), yaw)
    clip = np.zeros((frames, 7, 3))
    half = lengths.shoulder_width / 2
    centre = np.array([0.0, 0.0, depth])
    for i in range(frames):
        down, outward, forward = np.array([0, 1.0, 0]), np.array([out, 0, 0]), np.array(
            [0, 0, -1.0])
        horizontal = math.cos(azimuth[i]) * outward + math.sin(azimuth[i]) * forward
        upper = math.cos(elevation[i]) * down + math.sin(elevation[i]) * horizontal
        bend_axis = _rotation(upper, twist[i]) @ np.cross(upper, horizontal
                                                          if elevation[i] < 0.2 else down)
        if np.linalg.norm(bend_axis) < 1e-6:
            bend_axis = outward
        fore = _rotation(bend_axis, flexion[i]) @ upper
        if float(fore @ forward) < -0.2:  # keep the forearm out of the body
            fore = _rotation(bend_axis, -flexion[i]) @ upper
        hand = _rotation(bend_axis, 0.2) @ fore
        shoulder = np.array([out * half, -lengths.torso / 2, 0])
        elbow = shoulder + lengths.upper_arm * upper
        wrist = elbow + lengths.forearm * fore
        tip = wrist + lengths.hand * hand
        body = np.array([shoulder, elbow, wrist, tip, [-out * half, -lengths.torso / 2, 0],
                         [out * half * 0.7, lengths.torso / 2, 0],
                         [-out * half * 0.7, lengths.torso / 2, 0]])
        clip[i] = centre + body @ turn.T
    return clip


def model_depth_noise(rng: np.random.Generator, frames: int, scale: float,
                      correlation_s: float, fps: float) -> np.ndarray:
    """(frames, 7) Gaussian noise of standard deviation ``scale`` (m), each keypoint's
    low-passed over about ``correlation_s`` seconds (0: independent from frame to
    frame)."""
    white = rng.normal(0, 1, (frames, 7))
    if correlation_s <= 0:
        return scale * white
    keep = math.exp(-1.0 / (correlation_s * fps))
    noise = np.zeros_like(white)
    noise[0] = white[0]
    for i in range(1, frames):
        noise[i] = keep * noise[i - 1] + math.sqrt(1 - keep * keep) * white[i]
    return scale * noise


def run_synthetic(clips: int, noise_px: float, depth_noise: float, correlation_s: float,
                  flip_rate: float, settings: Settings) -> None:
    """The lift on synthetic clips: 2-D keypoints projected through a 640x480 camera with
    ``noise_px`` Gaussian pixel noise; the model's depth the true depth times a random
    gain in [0.5, 3] plus ``depth_noise`` (m) noise correlated over ``correlation_s``,
    and ``flip_rate`` bursts a second (2-6 frames each) in which the model turns the
    forearm's depth round (as MediaPipe does now and then); a person's lengths 0.9-1.1 of
    the prior's. Prints the elbow-flexion RMSE and the forearm direction error (median,
    p95) per setting."""
    from imimic_gym.spatial.lift import ArmLifter

    camera = Intrinsics.from_fovy(45, 640, 480)
    rng = np.random.default_rng(7)
    fps = 30.0
    data = []
    for _ in range(clips):
        person = BoneLengths(*(v * rng.uniform(0.9, 1.1) for v in (
            0.36, 0.50, 0.29, 0.25, 0.09)))
        truth = synthetic_clip(rng, 240, fps, person)
        pixels = camera.project(truth) + rng.normal(0, noise_px, (*truth.shape[:2], 2))
        gain = rng.uniform(0.5, 3.0)
        hips = 0.5 * (truth[:, 5, 2] + truth[:, 6, 2])
        relative = gain * (truth[..., 2] - hips[:, None])
        for start in np.flatnonzero(rng.random(len(truth)) < flip_rate / fps):
            burst = slice(start, start + int(rng.integers(2, 7)))
            relative[burst, 2:4] = 2 * relative[burst, 1:2] - relative[burst, 2:4]
        relative += model_depth_noise(rng, len(truth), depth_noise, correlation_s, fps)
        model_depth = relative * camera.fx / truth[:, :1, 2]
        data.append((truth, pixels, model_depth))
    for setting in settings:
        flex, fore = [], []
        for truth, pixels, model_depth in data:
            lifter = ArmLifter(camera, fps, **setting)
            for points, px, depth in zip(truth, pixels, model_depth, strict=True):
                pose = lifter("left", px, np.ones(7), depth)
                true = ArmPose("left", points, np.ones(7), px)
                flex.append(math.degrees(pose.elbow_flexion - true.elbow_flexion))
                fore.append(math.degrees(angle_between(pose.forearm, true.forearm)))
        print(f"{setting or 'defaults'}: flexion RMSE "
              f"{math.sqrt(np.mean(np.square(flex))):.2f} deg, forearm median "
              f"{np.median(fore):.2f} p95 {np.percentile(fore, 95):.2f} deg")


_NUMBERS = {"threshold": "sign_threshold", "quantile": "length_quantile",
            "noise": "keypoint_noise", "margin": "sign_margin", "patience": "flip_patience",
            "turn": "max_turn_rate"}


def parse_settings(text: list[str] | None) -> Settings:
    """Settings of the lift, each ``KEY=VALUE[;KEY=VALUE...]`` with keys ``points`` and
    ``pixels`` (MIN_CUTOFF,BETA or none: the One Euro filters), ``threshold`` (the sign
    threshold), ``quantile`` (the length quantile) and ``noise`` (the keypoint noise),
    ``margin`` (the sign margin), ``turn`` (the turn rate limit, rad/s) and ``patience``
    (s);
    none given: the defaults."""
    if not text:
        return [{}]
    settings: Settings = []
    for item in text:
        setting: dict[str, Any] = {}
        for part in filter(None, item.split(";")):
            key, value = part.split("=")
            if key in ("points", "pixels"):
                name = "smoothing" if key == "points" else "pixel_smoothing"
                setting[name] = (None if value == "none" else
                                 OneEuroSettings(*(float(v) for v in value.split(","))))
            elif key in _NUMBERS:
                setting[_NUMBERS[key]] = float(value)
            else:
                raise SystemExit(f"unknown setting {key!r}")
        settings.append(setting)
    return settings


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--video", nargs="*", default=[])
    parser.add_argument("--frames", type=int, default=None, help="first N frames only")
    parser.add_argument("--png", default=None, help="picture of the first video's frames")
    parser.add_argument("--min-confidence", type=float, default=0.5)
    parser.add_argument("--synthetic", type=int, default=0, metavar="CLIPS",
                        help="run the lift on this many synthetic clips instead")
    parser.add_argument("--noise", type=float, default=2.0, help="synthetic pixel noise")
    parser.add_argument("--depth-noise", type=float, default=0.05,
                        help="synthetic model-depth noise, metres")
    parser.add_argument("--correlation", type=float, default=0.0,
                        help="synthetic model-depth noise's correlation time, s")
    parser.add_argument("--flips", type=float, default=0.0,
                        help="synthetic model-depth flips of the forearm a second")
    parser.add_argument("--setting", nargs="*",
                        help="lift settings to compare: points=1.5,4;pixels=none;threshold=0.25")
    args = parser.parse_args()
    settings = parse_settings(args.setting)
    if args.synthetic:
        run_synthetic(args.synthetic, args.noise, args.depth_noise, args.correlation,
                      args.flips, settings)
    for video in args.video:
        if "realdata/videos" in video or "coco_mini" in video:
            raise SystemExit(f"{video}: evaluation footage; develop on realdata/dev only")
        png = args.png
        if png and len(args.video) > 1:
            png = str(Path(png).with_name(f"{Path(png).stem}_{Path(video).stem[:5]}.png"))
        run_video(video, args.frames, png, args.min_confidence, settings)


if __name__ == "__main__":
    main()
