"""CNN + refiner inference time per 240x320 frame, one thread, as a ratio to DON's.

Both estimators run over the same rendered frames (exp3-forearm-none, seed 1000) in the
same process, alternating, with torch and OpenCV on one thread; the median per-frame time
of each is reported, and CNN / DON.

    .venv/bin/python benchmarks/cnn_speed.py --json benchmarks/results/cnn_speed.json
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
import torch

from imimic_gym.bench import machine
from imimic_gym.clips.cache import load_clip
from imimic_gym.clips.scenarios import get_scenario
from imimic_gym.estimators.cnn import CNNEstimator
from imimic_gym.estimators.don import DON


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--frames", type=int, default=150, help="frames per timed run")
    parser.add_argument("--repeats", type=int, default=5, help="alternating runs each")
    parser.add_argument("--json", default=None, help="also write the result here")
    args = parser.parse_args()
    torch.set_num_threads(1)
    cv2.setNumThreads(1)
    spec = get_scenario("exp3-forearm-none", seed=1000, n_frames=args.frames)
    clip = load_clip(spec, progress=False)
    estimators = {"don": DON(fps=clip.fps), "cnn": CNNEstimator(n_links=1, fps=clip.fps),
                  "cnn_without_refiner": CNNEstimator(n_links=1, fps=clip.fps, refine=False)}
    times: dict[str, list[float]] = {name: [] for name in estimators}
    for _ in range(args.repeats):
        for name, estimator in estimators.items():
            start = time.perf_counter()
            estimator.run(clip.frames)
            times[name].append((time.perf_counter() - start) / len(clip.frames) * 1e3)
    result = {"machine": machine(), "frames": args.frames, "repeats": args.repeats,
              "resolution": f"{clip.height}x{clip.width}", "threads": 1,
              **{f"{name}_ms": float(np.median(t)) for name, t in times.items()}}
    result["ratio_cnn_to_don"] = result["cnn_ms"] / result["don_ms"]
    print(f"{result['resolution']}, one thread, median of {args.repeats} runs of "
          f"{args.frames} frames: DON {result['don_ms']:.2f} ms, CNN + refiner "
          f"{result['cnn_ms']:.2f} ms (CNN alone {result['cnn_without_refiner_ms']:.2f} ms); "
          f"CNN / DON = {result['ratio_cnn_to_don']:.2f}")
    if args.json:
        Path(args.json).write_text(json.dumps(result, indent=2) + "\n")
        print(f"wrote {args.json}")


if __name__ == "__main__":
    main()
