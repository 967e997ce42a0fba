"""Does the pose model take our rendered demonstrator for a person? On DEVELOPMENT clips
(seeds below 1000; 0-9 by default) of the spatial scenarios: the share of frames where
`PoseEstimator` (MediaPipe Pose, video mode, the arm chosen as `imimic eval` does) finds
the moving arm (the demonstrator's left), and on those frames the error of the elbow's
image angle (the forearm's direction from the upper arm's, 2-D, from the model's
shoulder, elbow and wrist pixels against the rendered keypoints): RMSE and 95th
percentile, degrees, on every such frame and on the frames where the arm lies across the
view (upper arm and forearm each within 45 degrees of the image plane: elsewhere a
foreshortened segment's image direction is ill-defined, a few pixels turning it by tens
of degrees). ``--body`` renders the scenarios with another figure (``mannequin``:
the figure before the person existed), ``--background`` on another wall; ``--scenarios``
takes the planar person scenarios too (``default``, ``chain-2``: their arm is always
across the view).

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
from imimic_gym.estimators.pose.planar import PoseEstimator
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
    found, errors, across = 0, [], []
    points = clip.truth.points3d
    in_view = np.ones(len(clip), dtype=bool)  # a planar arm moves in the image plane
    if points is not None:
        segments = np.stack([points[:, 1] - points[:, 0], points[:, 2] - points[:, 1]],
                            axis=1)
        in_view = np.all(np.abs(segments[..., 2]) < math.sin(math.radians(45))
                         * np.linalg.norm(segments, axis=-1), axis=1)
    truth = keypoints_to_angles(clip.truth.keypoints[:, :3], 1)[:, 0]
    for i, frame in enumerate(clip.frames):
        reading = estimator.read(frame, None, i / clip.fps)
        if reading is None or reading.side != MOVING:
            continue
        found += 1
        seen = keypoints_to_angles(reading.keypoints, 1)[0]
        errors.append(math.degrees(wrap_angle(seen - truth[i])))
        across.append(bool(in_view[i]))
    return {"scenario": name, "seed": seed, "frames": len(clip), "found": found,
            "errors": errors, "across": across}


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
    print(f"{'':16s} {'':>8s} {'all found frames':>22s} {'arm across the view':>28s}")
    print(f"{'scenario':16s} {'found %':>8s} {'RMSE':>6s} {'p95':>6s} {'bias':>6s} "
          f"{'frames %':>9s} {'RMSE':>6s} {'p95':>6s} {'bias':>6s}")

    def line(label: str, rows: list[dict[str, Any]]) -> None:
        errors = np.array([e for r in rows for e in r["errors"]])
        across = np.array([a for r in rows for a in r["across"]], dtype=bool)
        frames, found = sum(r["frames"] for r in rows), sum(r["found"] for r in rows)
        cells = [f"{label:16s} {100 * found / frames:8.1f}"]
        for chosen in (errors, errors[across]):
            if len(chosen):
                cells.append(f"{math.sqrt(float(np.mean(np.square(chosen)))):6.1f} "
                             f"{float(np.percentile(np.abs(chosen), 95)):6.1f} "
                             f"{float(np.mean(chosen)):6.1f}")
            else:
                cells.append(f"{'-':>6s} {'-':>6s} {'-':>6s}")
        cells.insert(2, f"{100 * across.sum() / max(found, 1):9.1f}")
        print(" ".join(cells))

    for name in args.scenarios:
        line(name, [r for r in results if r["scenario"] == name])
    line("all", results)
    if args.json:
        with open(args.json, "w") as f:
            json.dump(results, f)


if __name__ == "__main__":
    main()
