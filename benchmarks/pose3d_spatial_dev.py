"""Development only: ``pose3d`` and ``pose-world`` on the spatial scenarios' DEVELOPMENT
seeds (< 1000), the pose model's readings cached once and replayed, with oracles that
swap one part of the lift's input for the truth (`docs/decisions/pose3d-lift.md`).

    python benchmarks/pose3d_spatial_dev.py --cache /tmp/p3d --seeds 1-8
    python benchmarks/pose3d_spatial_dev.py --cache /tmp/p3d --seeds 1-8 --world \\
        --setting rules filter "filter:depth_noise=2" --oracles - sign px+len+sign
    python benchmarks/pose3d_spatial_dev.py --cache /tmp/p3d --seeds 1-4 --size 640x480
    python benchmarks/pose3d_spatial_dev.py --cache /tmp/p3d --seeds 1-8 --focal-scale 1.56

Printed per setting and oracle row: per scenario, the elbow-flexion RMSE / the forearm
direction error's median (degrees, pooled over the frames with a reading, as
`evaluation._evaluate_spatial` scores a clip), then the upper arm's median error.

Oracles (joined with ``+``; ``-`` none): ``px`` the truth's 2-D keypoints for the
model's; ``len`` the truth's bone lengths (no refinement); ``z0`` the truth's shoulder
depth; ``sign`` the truth's depths as the model's relative depths (the toward/away order
right, its scale the lift's).
"""

from __future__ import annotations

import argparse
import math
import pickle
import sys
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import imimic_gym.spatial.lift as lift_module
from imimic_gym.estimators.pose.planar import ArmChooser
from imimic_gym.estimators.pose.spatial import arm_keypoints
from imimic_gym.metrics import direction_error_deg
from imimic_gym.spatial import ArmPose, Intrinsics
from imimic_gym.spatial.lift import ArmLifter, BoneLengths, from_world_landmarks
from imimic_gym.spatial.share_filter import ShareFilter

SCENARIOS = ("spatial-reach", "spatial-cup", "spatial-raise", "spatial-curl", "spatial-wave",
             "spatial")
FIRST_TEST_SEED = 1000


def seeds(text: str) -> list[int]:
    low, _, high = text.partition("-")
    chosen = list(range(int(low), int(high or low) + 1))
    if max(chosen) >= FIRST_TEST_SEED:
        raise SystemExit(f"seeds {text}: development seeds are below {FIRST_TEST_SEED}")
    return chosen


def cache(folder: Path, scenario: str, seed: int, size: tuple[int, int] | None = None
          ) -> dict[str, Any]:
    """The clip's pose-model readings and truth, read once (rendering if need be);
    ``size`` (width, height) pixels, None: the scenario's own."""
    tag = "" if size is None else f"_{size[0]}x{size[1]}"
    path = folder / f"{scenario}_{seed}{tag}.pkl"
    if path.exists():
        with path.open("rb") as file:
            return dict(pickle.load(file))
    from imimic_gym.clips.cache import load_clip
    from imimic_gym.clips.scenarios import get_scenario
    from imimic_gym.estimators.pose.model import PoseModel

    spec = get_scenario(scenario).replace(seed=seed)
    if size is not None:
        spec = spec.replace(width=size[0], height=size[1])
    clip = load_clip(spec, progress=False)
    assert clip.truth is not None
    model = PoseModel(video=True)
    data = {"bodies": [model(frame, i / clip.fps) for i, frame in enumerate(clip.frames)],
            "points3d": clip.truth.points3d, "points2d": clip.truth.points2d,
            "intrinsics": clip.meta["intrinsics"], "side": clip.meta["arm_side"],
            "fps": float(clip.fps)}
    folder.mkdir(parents=True, exist_ok=True)
    with path.open("wb") as file:
        pickle.dump(data, file)
    return data


def parse_setting(text: str) -> dict[str, Any]:
    """``rules`` (the per-frame sign rules), ``filter`` (the defaults) or
    ``filter:KEY=VALUE,...`` (a `ShareFilter` over its defaults)."""
    if text == "rules":
        return {"share_filter": None}
    name, _, rest = text.partition(":")
    if name != "filter":
        raise SystemExit(f"unknown setting {text!r}")
    fields = dict(part.split("=") for part in filter(None, rest.split(",")))
    return {"share_filter": ShareFilter(**{k: float(v) for k, v in fields.items()})}


def true_lengths(points: np.ndarray) -> BoneLengths:
    def between(a: int, b: int) -> float:
        return float(np.linalg.norm(points[a] - points[b]))

    torso = float(np.linalg.norm(0.5 * (points[0] + points[4]) - 0.5 * (points[5] + points[6])))
    return BoneLengths(shoulder_width=between(0, 4), torso=torso, upper_arm=between(0, 1),
                       forearm=between(1, 2), hand=between(2, 3))


def replay(data: dict[str, Any], setting: dict[str, Any] | None, oracles: set[str],
           focal_scale: float = 1.0) -> list[ArmPose | None]:
    """The arm read each frame (None: no reading), as `Pose3DEstimator` reads it;
    ``setting`` None: pose-world. ``focal_scale``: the estimator reads through a camera
    whose focal length is that many times the true one (a wrong guess of an unknown
    camera); the truth stays in the true camera's frame."""
    true_camera = Intrinsics(**data["intrinsics"])
    camera = replace(true_camera, fx=true_camera.fx * focal_scale,
                     fy=true_camera.fy * focal_scale)
    chooser = ArmChooser(data["fps"])
    truth3d, truth2d = data["points3d"], data["points2d"]
    lengths = true_lengths(truth3d[0]) if "len" in oracles else None
    lifter = ArmLifter(camera, data["fps"], lengths=lengths, refine="len" not in oracles,
                       **(setting or {}))
    focal = math.sqrt(true_camera.fx * true_camera.fy)
    original = lift_module.shoulder_depth
    poses: list[ArmPose | None] = []
    try:
        for i, body in enumerate(data["bodies"]):
            if body is None:
                poses.append(None)
                continue
            side = chooser(body, i / data["fps"])
            rows = arm_keypoints(body, side)
            pixels, confidence = body.points[rows], body.confidence[rows]
            if confidence[:3].min() < 0.5:
                poses.append(None)
                continue
            if setting is None:
                z0 = original(pixels, confidence, camera, BoneLengths())
                poses.append(from_world_landmarks(side, body.world[rows], pixels, confidence,
                                                  camera, depth_of_shoulder=z0))
                continue
            depth = body.depth[rows] * camera.width
            if "px" in oracles:
                pixels = truth2d[i]
            if "z0" in oracles:
                lift_module.shoulder_depth = lambda *_, z=float(truth3d[i][0, 2]): z
            if "sign" in oracles:
                z0 = lift_module.shoulder_depth(pixels, confidence, camera,
                                                lifter.lengths(side))
                depth = truth3d[i][:, 2] * focal / z0
            poses.append(lifter(side, pixels, confidence, depth,
                                i / data["fps"]).within_elbow_range())
    finally:
        lift_module.shoulder_depth = original
    return poses


def score(data: dict[str, Any], poses: list[ArmPose | None]) -> np.ndarray:
    """(frames read, 3): flexion error, forearm and upper-arm direction errors, degrees."""
    side = data["side"]
    rows = []
    for pose, points, pixels in zip(poses, data["points3d"], data["points2d"], strict=True):
        if pose is None:
            continue
        true = ArmPose(side, points, np.ones(7), pixels)
        rows.append((math.degrees(pose.elbow_flexion - true.elbow_flexion),
                     float(direction_error_deg(pose.forearm[None], true.forearm[None])[0]),
                     float(direction_error_deg(pose.upper_arm[None], true.upper_arm[None])[0])))
    return np.array(rows).reshape(-1, 3)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--cache", type=Path, required=True)
    parser.add_argument("--seeds", type=seeds, default=seeds("1-8"))
    parser.add_argument("--scenarios", nargs="*", default=list(SCENARIOS))
    parser.add_argument("--setting", nargs="*", default=["filter"])
    parser.add_argument("--oracles", nargs="*", default=["-"])
    parser.add_argument("--world", action="store_true", help="score pose-world too")
    parser.add_argument("--focal-scale", type=float, default=1.0,
                        help="the lift's camera's focal length over the true one (default 1)")
    parser.add_argument("--size", type=lambda text: tuple(int(v) for v in text.split("x")),
                        default=None, help="WIDTHxHEIGHT to render at (default: the "
                        "scenario's own, 320x240)")
    args = parser.parse_args()
    clips = {name: [cache(args.cache, name, seed, args.size) for seed in args.seeds]
             for name in args.scenarios}
    runs: list[tuple[str, dict[str, Any] | None, set[str]]] = [
        (f"{text} {row}", parse_setting(text), set() if row == "-" else set(row.split("+")))
        for text in args.setting for row in args.oracles]
    if args.world:
        runs.insert(0, ("pose-world", None, set()))
    print("flexion RMSE / forearm median, deg: " + "  ".join(args.scenarios))
    for label, setting, oracles in runs:
        cells, upper = [], []
        for name in args.scenarios:
            errors = np.concatenate([score(d, replay(d, setting, oracles, args.focal_scale))
                                     for d in clips[name]])
            cells.append(f"{math.sqrt(np.mean(errors[:, 0] ** 2)):5.1f}/"
                         f"{np.median(errors[:, 1]):4.1f}")
            upper.append(f"{np.median(errors[:, 2]):4.1f}")
        print(f"{label:28s} {'  '.join(cells)} | upper arm {' '.join(upper)}", flush=True)


if __name__ == "__main__":
    main()
