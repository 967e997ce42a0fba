"""Does DON still give the same estimates as at another git revision?

Runs DON of this tree and of ``--base`` (exported with ``git archive`` into a temporary
folder and run in a subprocess that imports it) over the same clips: four scenarios,
seeds 0-2, each as the bench runs it (``DON()``), as `imimic eval` does (clip's fps,
reference direction, joint range), with the robot's model and the prediction layer on
(torques, predicted frames), and on the depth video. Compares every field of every
Estimate (angles, omega, alpha, torque, trust, predicted, keypoints) and the moving-pixel
count of each frame: "bit-identical", or the largest difference per field. Usage:

    .venv/bin/python benchmarks/don_same_estimates.py --base main \\
        --json benchmarks/results/don_same_estimates.json

``--head REV`` compares revision REV instead of the working tree.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

SCENARIOS = ("default", "exp2-servo", "exp3-forearm-low", "exp1-noisy-fast")
SEEDS = (0, 1, 2)
FIELDS = ("angles", "omega", "alpha", "torque", "trust", "predicted", "keypoints", "moving_px")
ROOT = Path(__file__).resolve().parent.parent


def capture(out: Path) -> None:
    """Every field of every DON estimate over the cases, saved to ``out`` (npz); uses
    whichever ``imimic_gym`` the interpreter imports."""
    from imimic_gym.clips.cache import load_clip
    from imimic_gym.clips.scenarios import get_scenario
    from imimic_gym.robots.planar import build_arm_model
    try:
        from imimic_gym.clips.types import depth_to_frame
    except ImportError:  # a revision from before it moved there
        from imimic_gym.envs.imitate_video import depth_to_frame  # type: ignore[no-redef]
    from imimic_gym.estimators.don.one_link import DON

    arrays: dict[str, np.ndarray] = {}
    for name in SCENARIOS:
        spec = get_scenario(name)
        robot = build_arm_model(spec.robot_arm())
        for seed in SEEDS:
            clip = load_clip(spec.replace(seed=seed), progress=False)
            evaluation = {"fps": clip.fps, "joint_range": spec.joint_ranges[0],
                          "reference_direction": float(clip.meta["reference_direction"])}
            cases = {"bench": ({}, clip.frames), "eval": (evaluation, clip.frames),
                     "robot_prediction": ({**evaluation, "robot": robot,
                                           "trust_threshold": 0.3}, clip.frames),
                     "depth": (evaluation, depth_to_frame(clip.depth))}
            for case, (params, frames) in cases.items():
                estimator, rows = DON(**params), {field: [] for field in FIELDS}
                for frame in frames:
                    estimate = estimator.update(frame)
                    for field in FIELDS[:6]:
                        rows[field].append(getattr(estimate, field))
                    rows["keypoints"].append(np.full((2, 2), np.nan) if estimate.keypoints
                                             is None else estimate.keypoints)
                    mask = estimator.last_mask
                    rows["moving_px"].append(0 if mask is None else np.count_nonzero(mask))
                for field, values in rows.items():
                    arrays[f"{name}/{seed}/{case}/{field}"] = np.array(values, dtype=np.float64)
    np.savez(out, **arrays)


def compare(base: Path, head: Path) -> dict[str, float]:
    """Largest absolute difference per field over all cases (0.0: bit-identical)."""
    old, new = np.load(base), np.load(head)
    if set(old.files) != set(new.files):
        raise ValueError(f"{base} and {head} hold different cases")
    worst = dict.fromkeys(FIELDS, 0.0)
    for key in old.files:
        a, b = old[key], new[key]
        if a.shape != b.shape:
            raise ValueError(f"{key}: shape {a.shape} at base, {b.shape} now")
        if not np.array_equal(a, b, equal_nan=True):
            field = key.rsplit("/", 1)[1]
            worst[field] = max(worst[field], float(np.nanmax(np.abs(a - b))))
    return worst


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--base", default="main", help="git revision to compare with")
    parser.add_argument("--head", default=None,
                        help="git revision to compare (default: this working tree)")
    parser.add_argument("--json", type=Path, default=None, help="also write results here")
    parser.add_argument("--capture", type=Path, default=None, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.capture:
        capture(args.capture)
        return
    revisions = {side: None if name is None else subprocess.run(
        ["git", "rev-parse", name], cwd=ROOT, check=True, capture_output=True,
        text=True).stdout.strip() for side, name in (("base", args.base), ("head", args.head))}
    with tempfile.TemporaryDirectory() as folder:
        paths = {"base": Path(folder) / "base.npz", "head": Path(folder) / "head.npz"}
        for side, path in paths.items():
            env = None  # the working tree's imimic_gym
            if revisions[side] is not None:  # an exported revision's, first on the path
                tree = Path(folder) / side
                tree.mkdir()
                archive = subprocess.run(["git", "archive", revisions[side], "imimic_gym"],
                                         cwd=ROOT, check=True, capture_output=True).stdout
                subprocess.run(["tar", "-x", "-C", str(tree)], input=archive, check=True)
                env = {**os.environ, "PYTHONPATH": str(tree)}
            subprocess.run([sys.executable, __file__, "--capture", str(path)], check=True,
                           env=env, cwd=folder)
        worst = compare(paths["base"], paths["head"])
    identical = not any(worst.values())
    head = "this tree" if args.head is None else f"{args.head} ({revisions['head'][:10]})"
    print(f"{head} against {args.base} ({revisions['base'][:10]}): "
          + ("bit-identical" if identical else f"largest differences {worst}"))
    if args.json:
        args.json.write_text(json.dumps({
            "base": args.base, "base_commit": revisions["base"], "head": args.head,
            "head_commit": revisions["head"], "scenarios": SCENARIOS,
            "seeds": SEEDS, "bit_identical": identical, "max_abs_difference": worst},
            indent=2) + "\n")


if __name__ == "__main__":
    main()
