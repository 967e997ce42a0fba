"""Where DON's time per frame goes, stage by stage, beside raw MOG2 in the same run.

Runs DON over the bench's frames (default scenario, 90 frames, one OpenCV thread), with
each stage's method wrapped in a timer, ``--repeats`` times; a stage's figure is its
smallest total over the runs, per frame (the machine is shared: the least disturbed run
is the closest to the cost; so the stages' figures come from different runs and are not
summed). Each wrapper adds its own cost per call (measured on a no-op and reported). The
whole frame is timed unwrapped (CPU time, median and minimum of as many runs) beside raw
OpenCV MOG2 on the same frames. Under cProfile, the time inside OpenCV's calls, inside
numpy's and Python's built-ins and inside DON's compiled loops (`estimators/compiled.py`),
against the same unwrapped time: what is left is the interpreter running DON's own Python,
the one cost a faster DON could drop without changing what it computes. Usage:

    .venv/bin/python benchmarks/don_stages.py --json benchmarks/results/don_stages.json
"""

from __future__ import annotations

import argparse
import cProfile
import functools
import json
import pstats
import time
import timeit
from collections.abc import Callable
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from imimic_gym.bench import machine, per_frame_ms, run_raw_mog2
from imimic_gym.clips.cache import load_clip
from imimic_gym.clips.scenarios import get_scenario
from imimic_gym.estimators import (
    appearance,
    compiled,
    don,
    frames,
    link_tracker,
    motion,
    motion_mask,
    pivot,
    regions,
)

# (owner, attribute, stage name); nested stages (a pivot solve inside `lines`) are
# reported on their own and inside their caller.
STAGES = (
    (frames.WorkingFrames, "__call__", "layer 1: downscale (+ Gaussian, if set)"),
    (motion_mask.MotionMask, "_moving_pixels", "layers 2-3: differences, union, l_1"),
    (don.DON, "_slow_reading", "slow link: delta2 half and a whole window back"),
    (motion_mask.SlidingExtrema, "push", "layer 2: sliding min/max update"),
    (link_tracker.LinkTracker, "lines", "regression: lines of regions (+ pivot lookups)"),
    (regions, "component_lines", "  of which component_lines"),
    (link_tracker.LinkTracker, "measure", "location s and visible length"),
    (pivot.PivotEstimator, "_solve", "pivot solves (inside lines / keypoints)"),
    (don.DON, "trust_factor", "layer 4b: trust factor"),
    (motion.PathEstimator, "update", "layer 4a: path estimator update"),
    (motion.PathEstimator, "omega", "layer 4a: omega"),
    (motion.PathEstimator, "alpha", "layer 4a: alpha"),
    (appearance.LinkAppearance, "update", "appearance layer (ours)"),
    (appearance.LinkAppearance, "_fit_line", "  of which the line fit"),
    (motion.PathEstimator, "correct", "appearance: path correction"),
    (don.DON, "_estimate", "Estimate (+ keypoints)"),
)


def _timed(function: Callable, totals: dict[str, float], name: str) -> Callable:
    @functools.wraps(function)
    def wrapper(*args, **kwargs):
        start = time.perf_counter()
        try:
            return function(*args, **kwargs)
        finally:
            totals[name] += time.perf_counter() - start
    return wrapper


def timer_overhead_us(calls: int = 100_000) -> float:
    """What one timer wrapper adds to a call, us: a wrapped no-op against the bare one
    (least of 5 rounds each)."""
    def no_op() -> None:
        return None

    wrapped = _timed(no_op, {"no-op": 0.0}, "no-op")
    bare, timed = (min(timeit.repeat(fn, number=calls, repeat=5)) / calls * 1e6
                   for fn in (no_op, wrapped))
    return timed - bare


def stage_times(clip_frames: np.ndarray, repeats: int) -> dict[str, float]:
    """us per frame of each stage: the smallest total over ``repeats`` runs."""
    totals = dict.fromkeys((name for *_, name in STAGES), 0.0)
    originals = [(owner, attribute, getattr(owner, attribute)) for owner, attribute, _ in STAGES]
    for owner, attribute, name in STAGES:
        setattr(owner, attribute, _timed(getattr(owner, attribute), totals, name))
    best = dict.fromkeys(totals, float("inf"))
    try:
        for _ in range(repeats):
            totals.update(dict.fromkeys(totals, 0.0))
            don.DON().run(clip_frames)
            for name, total in totals.items():
                best[name] = min(best[name], total / len(clip_frames) * 1e6)
    finally:
        for owner, attribute, original in originals:
            setattr(owner, attribute, original)
    return best


def library_time_us(clip_frames: np.ndarray, repeats: int) -> dict[str, Any]:
    """us per frame DON spends inside OpenCV's calls, inside numpy's and Python's
    built-in calls (cProfile's own time of each built-in) and inside its compiled loops
    (`estimators/compiled.py`): what the same calls would cost with no time in the
    interpreter running DON's Python. Each of ``repeats`` runs is
    paired with a raw MOG2 run on the same frames, unprofiled, right after it, for its
    ratio (``ratios_mog2``: the paired runs' sum of both kinds / MOG2); the per-kind
    figures are the least over the runs. The profiler's hooks add a little to each call,
    so these lean high."""
    best = {"opencv": float("inf"), "numpy_and_builtins": float("inf"),
            "compiled": float("inf")}
    ratios = []
    for _ in range(repeats):
        profile = cProfile.Profile()
        profile.enable()
        don.DON().run(clip_frames)
        profile.disable()
        mog2_ms = per_frame_ms(run_raw_mog2, clip_frames)
        totals = dict.fromkeys(best, 0.0)
        for (filename, _, name), (*_, own, _, _) in pstats.Stats(profile).stats.items():
            if filename == "~":  # a built-in: OpenCV's are listed as "<name>"
                kind = "opencv" if hasattr(cv2, name.strip("<>")) else "numpy_and_builtins"
                totals[kind] += own
            elif filename == compiled.__file__:  # numba's machine code, listed as Python
                totals["compiled"] += own
        per_frame = {kind: total / len(clip_frames) * 1e6 for kind, total in totals.items()}
        ratios.append(sum(per_frame.values()) / 1e3 / mog2_ms)
        for kind, us in per_frame.items():
            best[kind] = min(best[kind], us)
    return {"us_per_frame": best, "ratios_mog2": ratios}


def whole_runs_ms(clip_frames: np.ndarray, repeats: int) -> dict[str, list[float]]:
    """CPU ms per frame (as `imimic bench don` times them) of unwrapped DON and of raw
    MOG2 (``apply`` on the full frame), alternating, ``repeats`` runs each."""
    runs: dict[str, list[float]] = {"don": [], "mog2_raw": []}
    for _ in range(repeats):
        runs["don"].append(per_frame_ms(lambda f: don.DON().run(f), clip_frames))
        runs["mog2_raw"].append(per_frame_ms(run_raw_mog2, clip_frames))
    return runs


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeats", type=int, default=25, help="timed runs (default 25)")
    parser.add_argument("--height", type=int, default=240, help="frame rows (default 240)")
    parser.add_argument("--width", type=int, default=320, help="frame columns (default 320)")
    parser.add_argument("--json", type=Path, default=None, help="also write results here")
    args = parser.parse_args()
    cv2.setNumThreads(1)
    clip = load_clip(get_scenario("default", height=args.height, width=args.width,
                                  n_frames=90), progress=False)
    don.DON().run(clip.frames)  # warm-up
    stages = stage_times(clip.frames, args.repeats)
    overhead = timer_overhead_us()
    runs = whole_runs_ms(clip.frames, args.repeats)
    library_runs = min(args.repeats, 9)
    library = library_time_us(clip.frames, library_runs)
    summary = {f"{name}_ms_{stat.__name__}": float(stat(times))
               for name, times in runs.items() for stat in (np.median, np.min)}
    summary["ratio_mog2_median"] = summary["don_ms_median"] / summary["mog2_raw_ms_median"]
    summary["ratio_mog2_min"] = summary["don_ms_min"] / summary["mog2_raw_ms_min"]
    summary["library_us_per_frame"] = library["us_per_frame"]
    summary["library_runs"] = library_runs
    summary["library_ratios_mog2"] = library["ratios_mog2"]
    ratios = library["ratios_mog2"]
    for name, us in stages.items():
        print(f"{name:48s} {us:7.1f} us/frame")
    inside = library["us_per_frame"]
    print(f"inside OpenCV's calls {inside['opencv']:.0f} us/frame, numpy's and Python's "
          f"built-ins {inside['numpy_and_builtins']:.0f}, compiled loops "
          f"{inside['compiled']:.0f}: with no interpreter time, DON / "
          f"raw MOG2 {np.median(ratios):.3f} (median of {len(ratios)} paired runs; "
          f"{min(ratios):.3f}-{max(ratios):.3f})")
    print(f"(each timer adds {overhead:.2f} us per call)")
    print(f"DON {summary['don_ms_median']:.3f} ms/frame (min {summary['don_ms_min']:.3f}), "
          f"raw MOG2 {summary['mog2_raw_ms_median']:.3f} (min {summary['mog2_raw_ms_min']:.3f})"
          f": ratio {summary['ratio_mog2_median']:.3f} (of minima {summary['ratio_mog2_min']:.3f})")
    if args.json:
        args.json.write_text(json.dumps({
            "machine": machine(), "resolution": f"{args.height}x{args.width}", "frames": 90,
            "repeats": args.repeats, "opencv_threads": 1, "stages_us_per_frame": stages,
            "timer_overhead_us_per_call": overhead,
            **summary}, indent=2) + "\n")


if __name__ == "__main__":
    main()
