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
constants of `estimators/pose_don.py` in ``TUNABLE`` can be set with ``--param
NAME=VALUE`` (repeatable; angles in degrees).

With ``--video FILE`` it scores pose-seeded DON on footage of one's own instead, against
the real pose model read on every frame (no truth there: agreement with the reference,
as the `real` suite measures it), split by what gave each estimate. That is the loop for
developing on real people without touching the shared evaluation clips.

    .venv/bin/python benchmarks/pose_don_dev_seeds.py                      # defaults
    .venv/bin/python benchmarks/pose_don_dev_seeds.py --noise 2 --param GAIN=1.0
    .venv/bin/python benchmarks/pose_don_dev_seeds.py --pose-every 4 --no-don
    .venv/bin/python benchmarks/pose_don_dev_seeds.py --video my_camera.mp4 --param GAIN=1
"""

from __future__ import annotations

import argparse
import math
import os
from typing import cast

os.environ.setdefault("MUJOCO_GL", "egl")

import cv2
import numpy as np

from imimic_gym.bench import machine
from imimic_gym.clips.cache import load_clip
from imimic_gym.clips.dataset import randomised_spec
from imimic_gym.estimators import pose_don
from imimic_gym.estimators.pose_model import KEYPOINTS, BodyKeypoints, PoseModel
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


def run_video(path: str, pose_every: int) -> None:
    """Pose-seeded DON on a video of one's own (development footage, not the shared
    evaluation clips), against the real pose model read on every frame: the RMSE over
    the frames both read, split by what gave each estimate."""
    from imimic_gym.clips.video import VideoReader
    from imimic_gym.estimators.pose import PoseEstimator

    with VideoReader(path).open() as reader:
        fps = float(reader.fps)
    reference, estimator = PoseEstimator(fps=fps), pose_don.PoseSeededDON(
        fps=fps, pose_every=pose_every)
    reference.reset()
    estimator.reset()
    rows = []
    for frame in VideoReader(path):
        truth, estimate = reference.update(frame), estimator.update(frame)
        if truth.trust > 0 and estimate.trust > 0:
            error = math.degrees(abs(float(wrap_angle(estimate.angles[0] - truth.angles[0]))))
            rows.append((estimator.source, error))
    if not rows:
        print(f"  {path}: the pose model and pose-seeded DON never both read the arm")
        return
    errors = np.array([e for _, e in rows])
    split = "; ".join(f"{name} {np.sqrt(np.mean(np.square(part))):.2f} ({len(part)})"
                      for name in ("pose", "don", "rolled")
                      if (part := [e for source, e in rows if source == name]))
    print(f"  {path}: RMSE vs the every-frame pose model {np.sqrt(np.mean(errors ** 2)):.2f} "
          f"deg over {len(errors)} frames, largest {errors.max():.1f}; by source: {split}; "
          f"pose frames {estimator.pose_frames}")


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
    parser.add_argument("--param", action="append", default=[], metavar="NAME=VALUE",
                        help="a constant of estimators/pose_don.py: " + ", ".join(TUNABLE)
                             + " (angles in degrees)")
    args = parser.parse_args()
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
            run_video(path, args.pose_every)
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
