"""Does the pose model take our rendered demonstrator for a person? On DEVELOPMENT clips
(seeds below 1000; 0-9 by default) of the spatial scenarios: the share of frames where
`PoseEstimator` (MediaPipe Pose, video mode, the arm chosen as `imimic eval` does) finds
the moving arm (the demonstrator's left), and on those frames the error of the elbow's
image angle (the forearm's direction from the upper arm's, 2-D, from the model's
shoulder, elbow and wrist pixels against the rendered keypoints): RMSE and 95th
percentile, degrees. ``--body`` renders the scenarios with another figure (``mannequin``:
the figure before the person existed), ``--background`` on another wall.

    .venv/bin/python benchmarks/pose_on_person.py                         # person
    .venv/bin/python benchmarks/pose_on_person.py --body mannequin        # before
    .venv/bin/python benchmarks/pose_on_person.py --background cluttered
"""

from __future__ import annotations

import argparse
import json
import math
import os
from multiprocessing import Pool
from typing import Any

os.environ.setdefault("MUJOCO_GL", "egl")

import numpy as np

from imimic_gym.clips.cache import load_clip
from imimic_gym.clips.scenarios import get_scenario
from imimic_gym.estimators.pose import PoseEstimator
from imimic_gym.kinematics import keypoints_to_angles, wrap_angle
from imimic_gym.suite import FIRST_HELD_OUT_SEED

SCENARIOS = ("spatial-reach", "spatial-cup", "spatial-raise", "spatial-curl", "spatial-wave",
             "spatial")
MOVING = "left"


def run_clip(job: tuple[str, int, str, str]) -> dict[str, Any]:
    name, seed, body, background = job
    clip = load_clip(get_scenario(name, seed=seed, body=body, background=background),
                     progress=False)
    estimator = PoseEstimator(n_links=1, fps=clip.fps)
    estimator.reset()
    found, errors = 0, []
    truth = keypoints_to_angles(clip.truth.keypoints[:, :3], 1)[:, 0]
    for i, frame in enumerate(clip.frames):
        reading = estimator.read(frame, None, i / clip.fps)
        if reading is None or reading.side != MOVING:
            continue
        found += 1
        seen = keypoints_to_angles(reading.keypoints, 1)[0]
        errors.append(math.degrees(wrap_angle(seen - truth[i])))
    return {"scenario": name, "seed": seed, "frames": len(clip), "found": found,
            "errors": errors}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--scenarios", nargs="+", default=list(SCENARIOS))
    parser.add_argument("--seeds", nargs=2, type=int, default=(0, 10), metavar=("FIRST", "END"))
    parser.add_argument("--body", choices=("person", "mannequin"), default="person")
    parser.add_argument("--background", choices=("plain", "textured", "cluttered"),
                        default="plain")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--json", help="write every clip's figures here")
    args = parser.parse_args()
    first, end = args.seeds
    if end > FIRST_HELD_OUT_SEED or first < 0:
        parser.error(f"development seeds only: 0 to {FIRST_HELD_OUT_SEED}")
    jobs = [(s, seed, args.body, args.background) for s in args.scenarios
            for seed in range(first, end)]
    with Pool(args.workers) as pool:
        results = pool.map(run_clip, jobs)
    print(f"body={args.body} background={args.background} seeds {first}-{end - 1}")
    print(f"{'scenario':16s} {'found %':>8s} {'elbow RMSE':>11s} {'p95 |err|':>10s}")
    every: list[float] = []
    frames = found = 0
    for name in args.scenarios:
        rows = [r for r in results if r["scenario"] == name]
        errors = np.concatenate([r["errors"] for r in rows]) if rows else np.zeros(0)
        n, k = sum(r["frames"] for r in rows), sum(r["found"] for r in rows)
        frames, found = frames + n, found + k
        every += list(errors)
        rmse = math.sqrt(float(np.mean(np.square(errors)))) if len(errors) else math.nan
        p95 = float(np.percentile(np.abs(errors), 95)) if len(errors) else math.nan
        print(f"{name:16s} {100 * k / n:8.1f} {rmse:11.1f} {p95:10.1f}")
    rmse = math.sqrt(float(np.mean(np.square(every)))) if every else math.nan
    p95 = float(np.percentile(np.abs(every), 95)) if every else math.nan
    print(f"{'all':16s} {100 * found / frames:8.1f} {rmse:11.1f} {p95:10.1f}")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(results, f)


if __name__ == "__main__":
    main()
