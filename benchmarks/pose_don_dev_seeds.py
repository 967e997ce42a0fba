"""Pose-seeded DON on DEVELOPMENT clips, for choosing how it carries the forearm between
pose frames without touching real footage (which is for evaluation only).

The clips: a person drawn at random (`clips.dataset.randomised_spec`: clothing, backdrop,
light, camera place, sway; smooth random elbow motion), seeds 700-711 by default (the
development block), 300 frames rendered at 540x960 and upscaled to 1920x1080, as a
1080p video would reach `imimic mimic`. The pose model is an oracle: the clip's true
shoulder, elbow and wrist plus Gaussian noise of ``--noise`` px a coordinate, drawn once
per frame (so the every-frame reference and pose-seeded DON see the same reading on the
same frame). MediaPipe itself misses or flips our mannequin's arm on many frames, so
its errors there would drown what is being chosen: what DON carries between pose frames
and how the pose readings are weighed.

Per setting: the RMSE (deg, every frame, mean over clips) of pose-seeded DON against the
oracle read on every frame (what the `real` suite compares against, there with MediaPipe)
and against the exact truth, the largest error, the frames the oracle read, and of the
frames between, those DON's turns carried and those rolled on at the pose rate. The
constants of `estimators/pose/seeded_don.py` in ``TUNABLE`` can be set with ``--param
NAME=VALUE`` (repeatable; angles in degrees).

With ``--video FILE`` it scores pose-seeded DON on footage of one's own instead, against
the real pose model read on every frame (no truth there: agreement with the reference,
as the `real` suite measures it), split by what gave each estimate, with its time a
frame over OpenCV's decode and what a line drawn in hindsight between the reference's
own readings at the pose rate leaves (a floor for any carrier that turns steadily between
pose frames); ``--steps`` adds DON's turn a frame against the reference's. That is the
loop for developing on real people without touching the shared evaluation clips.

    .venv/bin/python benchmarks/pose_don_dev_seeds.py                      # defaults
    .venv/bin/python benchmarks/pose_don_dev_seeds.py --noise 2 --param GAIN=1.0
    .venv/bin/python benchmarks/pose_don_dev_seeds.py --pose-every 4 --no-don
    .venv/bin/python benchmarks/pose_don_dev_seeds.py --video my_camera.mp4 --param GAIN=1
    .venv/bin/python benchmarks/pose_don_dev_seeds.py --video a.mp4 --video b.avi \
        --frames 240 --pose-every 4 --steps
"""

from __future__ import annotations

import argparse
import math
import os
import time
from typing import cast

os.environ.setdefault("MUJOCO_GL", "egl")

import cv2
import numpy as np

from imimic_gym.bench import machine
from imimic_gym.clips.cache import load_clip
from imimic_gym.clips.dataset import randomised_spec
from imimic_gym.estimators import pose_don
from imimic_gym.estimators.pose.model import KEYPOINTS, BodyKeypoints, PoseModel
from imimic_gym.kinematics import keypoints_to_angles, wrap_angle

ANGLES = {"DISAGREE", "MAX_STEP"}  # constants held in rad, given in degrees
TUNABLE = ("GAIN", "DISAGREE", "MAX_STEP", "MOVE", "SCALE", "REACH", "MIN_SIDE")
UPSCALE = 2  # 540x960 -> 1080x1920


class OraclePose:
    """A pose model that reports the true arm of frame ``t`` (set before each call) with
    fixed per-frame noise; the person's right arm hangs still and unconfident."""

    def __init__(self, keypoints: np.ndarray, noise: float, seed: int) -> None:
        self.keypoints, self.noise, self.seed, self.t = keypoints, noise, seed, 0

    def reset(self) -> None:
        pass

    def arm(self, t: int) -> np.ndarray:
        """Frame ``t``'s shoulder, elbow, wrist (3, 2) px as the oracle reads them."""
        jitter = np.random.default_rng((self.seed, t)).normal(0.0, self.noise, (3, 2))
        return self.keypoints[t, :3] + jitter

    def __call__(self, frame: np.ndarray, time_s: float | None = None) -> BodyKeypoints:
        shoulder, elbow, wrist = self.arm(self.t)
        hand = self.keypoints[self.t, 3]
        offsets = {"left_hip": (0, 300), "right_shoulder": (-150, 0),
                   "right_elbow": (-150, 150), "right_wrist": (-150, 300),
                   "right_hand": (-150, 320), "right_hip": (-80, 300)}
        points = {"left_shoulder": shoulder, "left_elbow": elbow, "left_wrist": wrist,
                  "left_hand": hand, **{name: shoulder + np.array(offset, float)
                                        for name, offset in offsets.items()}}
        confidence = np.array([0.1 if name.startswith("right") else 0.95 for name in KEYPOINTS])
        return BodyKeypoints(np.array([points[name] for name in KEYPOINTS], float), confidence)


def run_clip(seed: int, pose_every: int, noise: float, fps: float) -> dict[str, float]:
    spec = randomised_spec(1, seed, np.random.default_rng(seed)).replace(
        n_frames=300, height=540, width=960, fps=fps)
    clip = load_clip(spec, progress=False)
    assert clip.truth is not None  # a rendered clip
    keypoints = clip.truth.keypoints.astype(np.float64) * UPSCALE
    oracle = OraclePose(keypoints, noise, seed)
    estimator = pose_don.PoseSeededDON(fps=clip.fps, arm="left", pose_every=pose_every,
                                       model=cast(PoseModel, oracle))  # same calls
    estimator.reset()
    size = (clip.width * UPSCALE, clip.height * UPSCALE)
    angles, sources = [], []
    for t, frame in enumerate(clip.frames):
        oracle.t = t
        big = cv2.resize(frame, size, interpolation=cv2.INTER_LINEAR)
        angles.append(float(estimator.update(big).angles[0]))
        sources.append(estimator.source)
    truth = np.array([keypoints_to_angles(k[:3], 1)[0] for k in keypoints])
    read = np.array([keypoints_to_angles(oracle.arm(t), 1)[0] for t in range(len(truth))])
    versus_read = np.degrees(np.abs(wrap_angle(np.array(angles) - read)))
    versus_truth = np.degrees(np.abs(wrap_angle(np.array(angles) - truth)))
    return {"rmse_vs_read": float(np.sqrt(np.mean(versus_read ** 2))),
            "rmse_vs_truth": float(np.sqrt(np.mean(versus_truth ** 2))),
            "max_vs_read": float(versus_read.max()), "pose_frames": estimator.pose_frames,
            "don_frames": sources.count("don"), "rolled_frames": sources.count("rolled")}


STEP_BANDS = (0.0, 2.0, 10.0, math.inf)  # deg a frame: the reference's turn, slow to fast


class _TurnLog(pose_don.PoseSeededDON):
    """Pose-seeded DON that also logs, per frame, DON's forearm direction (rad, None: no
    reading), how many times DON was seeded so far, and what gave the estimate."""

    def reset(self) -> None:
        super().reset()
        self.log: list[tuple[float | None, int, str]] = []
        self.seeds, self.read_direction = 0, None

    def _seed(self, frame: np.ndarray, reading) -> None:
        super()._seed(frame, reading)
        self.seeds += 1

    def _don_direction(self, don):
        self.read_direction = super()._don_direction(don)
        return self.read_direction

    def update(self, frame: np.ndarray):
        self.read_direction = None
        estimate = super().update(frame)
        self.log.append((self.read_direction, self.seeds, self.source))
        return estimate


def _rms(values) -> float:
    return float(np.sqrt(np.mean(np.square(values)))) if len(values) else math.nan


def _hindsight(reference: list[float | None], every: int) -> float:
    """RMSE (deg) of a line drawn between the reference's own readings on every
    ``every``-th frame, knowing the next one (so no live estimator can do it), against the
    reference on the frames between: what reading the pose model that often leaves to
    carry, at best, by a carrier that turns at a steady rate between them."""
    errors = []
    for start in range(0, len(reference) - every, every):
        a, b = reference[start], reference[start + every]
        if a is None or b is None:
            continue
        turn = float(wrap_angle(b - a))
        for k in range(1, every):
            value = reference[start + k]
            if value is not None:
                errors.append(math.degrees(abs(float(wrap_angle(a + turn * k / every - value)))))
    return _rms(errors)


def run_video(path: str, pose_every: int, frames: int | None, steps: bool) -> None:
    """Pose-seeded DON on a video of one's own (development footage, not the shared
    evaluation clips), against the real pose model read on every frame: the RMSE over
    the frames both read, split by what gave each estimate; its time a frame over
    OpenCV's decode of the same frames in the same run. With ``steps``: per step between
    frames, DON's turn against the reference's, by how fast the reference turns."""
    from itertools import islice

    from imimic_gym.clips.video import VideoReader
    from imimic_gym.estimators.pose.planar import PoseEstimator

    with VideoReader(path).open() as reader:
        fps = float(reader.fps)
    started = time.perf_counter()
    decoded = sum(1 for _ in islice(VideoReader(path), frames))
    decode = (time.perf_counter() - started) / max(decoded, 1)
    reference = PoseEstimator(fps=fps)
    estimator = _TurnLog(fps=fps, pose_every=pose_every)
    reference.reset()
    estimator.reset()
    rows, seen, sides, spent = [], [], [], 0.0
    for frame in islice(VideoReader(path), frames):
        truth = reference.update(frame)
        started = time.perf_counter()
        estimate = estimator.update(frame)
        spent += time.perf_counter() - started
        seen.append(float(truth.angles[0]) if truth.trust > 0 else None)
        sides.append((reference.last.side if reference.last is not None else None,
                      estimator.last.side if estimator.last is not None else None))
        if truth.trust > 0 and estimate.trust > 0:
            error = math.degrees(abs(float(wrap_angle(estimate.angles[0] - truth.angles[0]))))
            rows.append((estimator.source, error))
    name = os.path.basename(path)
    if not rows:
        print(f"  {name}: the pose model and pose-seeded DON never both read the arm")
        return
    errors = np.array([e for _, e in rows])
    split = "; ".join(f"{source} {_rms(part):.2f} ({len(part)})"
                      for source in ("pose", "don", "rolled")
                      if (part := [e for s, e in rows if s == source]))
    print(f"  {name}: {len(seen)} frames; RMSE vs the every-frame pose model "
          f"{_rms(errors):.2f} deg over {len(errors)} frames, largest {errors.max():.1f}; "
          f"by source: {split}; pose frames {estimator.pose_frames}; "
          f"{spent / len(seen) / decode:.2f}x decode ({1e3 * decode:.1f} ms a frame); "
          f"a line between every {pose_every}th reference reading, in hindsight: "
          f"{_hindsight(seen, pose_every):.2f}")
    if steps:
        bands: list[list[float | None]] = [[] for _ in STEP_BANDS[1:]]
        for t in range(1, len(seen)):
            before, now = seen[t - 1], seen[t]
            (d0, seeds0, source0), (d1, seeds1, _) = estimator.log[t - 1], estimator.log[t]
            if (before is None or now is None or sides[t][0] != sides[t][1]
                    or source0 == "pose"):  # a pose frame moves DON's pivot: no clean step
                continue
            turn = math.degrees(float(wrap_angle(now - before)))
            band = int(np.searchsorted(STEP_BANDS, abs(turn), side="right")) - 1
            read = d0 is not None and d1 is not None and seeds0 == seeds1
            bands[band].append(math.degrees(float(wrap_angle(d1 - d0))) - turn
                               if read else None)
        print("    DON's turn a frame against the reference's: " + "; ".join(
            f"reference {low:g}-{high:g} deg a frame: {len(band)} steps, DON read "
            f"{sum(e is not None for e in band) / max(len(band), 1):.0%}, error "
            f"{_rms([e for e in band if e is not None]):.1f} deg RMS"
            for low, high, band in zip(STEP_BANDS[:-1], STEP_BANDS[1:], bands, strict=True)))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seeds", type=int, nargs=2, default=(700, 712), metavar=("FIRST", "END"),
                        help="development seeds FIRST..END-1 (default: 700 712)")
    parser.add_argument("--pose-every", type=int, default=5,
                        help="the pose model reads every this many frames (default: 5)")
    parser.add_argument("--noise", type=float, default=2.0,
                        help="the oracle's keypoint noise, px a coordinate at 1080p (default: 2)")
    parser.add_argument("--fps", type=float, default=30.0,
                        help="the clips' frame rate: the same motions filmed faster turn "
                             "less a frame, as a slow movement does (default: 30)")
    parser.add_argument("--no-don", action="store_true",
                        help="DON never reads: between pose frames the estimate only rolls on")
    parser.add_argument("--video", action="append", default=[], metavar="FILE",
                        help="instead of rendered clips, score it on this video of your own "
                             "against the real pose model read on every frame (repeatable; "
                             "not the shared evaluation clips)")
    parser.add_argument("--frames", type=int, default=None, metavar="N",
                        help="with --video: only the first N frames of each (default: all)")
    parser.add_argument("--steps", action="store_true",
                        help="with --video: also DON's turn a frame against the reference's, "
                             "by how fast the reference turns")
    parser.add_argument("--param", action="append", default=[], metavar="NAME=VALUE",
                        help="a constant of estimators/pose/seeded_don.py: " + ", ".join(TUNABLE)
                             + " (angles in degrees)")
    args = parser.parse_args()
    if args.frames is not None and args.frames < 1:
        parser.error(f"--frames takes a whole number of frames >= 1, got {args.frames}")
    for setting in args.param:
        name, _, value = setting.partition("=")
        if name not in TUNABLE:
            parser.error(f"--param {setting}: the constants to set are {', '.join(TUNABLE)}")
        number = float(value)
        setattr(pose_don, name, math.radians(number) if name in ANGLES else number)
    if args.no_don:
        pose_don.PoseSeededDON._don_direction = lambda self, don: None  # type: ignore[method-assign]
    settings = " ".join(args.param + ["no DON"] * args.no_don) or "defaults"
    if args.video:
        print(f"{machine()}\npose_every {args.pose_every}, {settings}")
        for path in args.video:
            run_video(path, args.pose_every, args.frames, args.steps)
        return
    rows = [run_clip(seed, args.pose_every, args.noise, args.fps)
            for seed in range(*args.seeds)]
    print(f"{machine()}\npose_every {args.pose_every}, noise {args.noise:g} px, {settings}, "
          f"{args.fps:g} fps, seeds {args.seeds[0]}-{args.seeds[1] - 1}")
    clips = " ".join(f"{r['rmse_vs_read']:.1f}" for r in rows)
    print(f"  RMSE vs the every-frame reading {np.mean([r['rmse_vs_read'] for r in rows]):.2f} "
          f"deg (clips: {clips}), "
          f"vs truth {np.mean([r['rmse_vs_truth'] for r in rows]):.2f}, largest "
          f"{max(r['max_vs_read'] for r in rows):.1f}, pose frames "
          f"{sum(r['pose_frames'] for r in rows)} of {300 * len(rows)}; between them DON's "
          f"turns on {sum(r['don_frames'] for r in rows)}, rolled on on "
          f"{sum(r['rolled_frames'] for r in rows)}")


if __name__ == "__main__":
    main()
