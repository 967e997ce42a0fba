"""DON for several links (`LinkedDON`): milliseconds per 240x320 frame, one thread, as a
ratio to the one-link DON on the same frames.

Per scenario (chain-2, chain-3, exp4-hand; clip seed 1000, 150 frames), both estimators
run over the same rendered frames in the same process, alternating, OpenCV on one
thread; the median per-frame time of each over the repeats is reported, and
LinkedDON / DON.

    .venv/bin/python benchmarks/don_links_speed.py --json benchmarks/results/don_links_speed.json
"""

from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")

import cv2
import numpy as np

from imimic_gym.bench import machine
from imimic_gym.clips.cache import load_clip
from imimic_gym.clips.scenarios import get_scenario
from imimic_gym.estimators.don import DON
from imimic_gym.estimators.registry import build_estimator
from imimic_gym.evaluation import clip_context

SCENARIOS = ("chain-2", "chain-3", "exp4-hand")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--repeats", type=int, default=3, help="alternating runs each")
    parser.add_argument("--json", default=None, help="also write the result here")
    args = parser.parse_args()
    cv2.setNumThreads(1)
    rows = []
    for name in SCENARIOS:
        spec = get_scenario(name, seed=1000)
        clip = load_clip(spec, progress=False)
        estimators = {
            "don": DON(fps=clip.fps, reference_direction=spec.reference_direction,
                       joint_range=spec.joint_ranges[0]),
            "linked": build_estimator("don", clip_context(spec, clip)),
        }
        times: dict[str, list[float]] = {key: [] for key in estimators}
        for _ in range(args.repeats):
            for key, estimator in estimators.items():
                start = time.perf_counter()
                estimator.run(clip.frames)
                times[key].append((time.perf_counter() - start) / len(clip.frames) * 1e3)
        row = {"scenario": name, "links": spec.n_links,
               **{f"{key}_ms": float(np.median(t)) for key, t in times.items()}}
        row["ratio_linked_to_don"] = row["linked_ms"] / row["don_ms"]
        rows.append(row)
        print(f"{name:10s} DON {row['don_ms']:.2f} ms, LinkedDON {row['linked_ms']:.2f} ms "
              f"per frame; LinkedDON / DON = {row['ratio_linked_to_don']:.1f}", flush=True)
    result = {"machine": machine(), "resolution": "240x320", "threads": 1,
              "repeats": args.repeats, "frames": 150, "rows": rows}
    if args.json:
        Path(args.json).write_text(json.dumps(result, indent=2) + "\n")
        print(f"wrote {args.json}")


if __name__ == "__main__":
    main()
