"""`imimic mimic --video` on the real clips in ../shared/realdata/videos: speed and what
DON's estimate does on footage it was not built for.

Evaluation only: the footage is read from ../shared/realdata (never copied into the
repository) and the side-by-side videos go to --out (not committed). Without the folder
the script says so and writes nothing. Usage:

    .venv/bin/python benchmarks/real_footage.py --json benchmarks/results/real_footage.json

Per clip and setting it records: frames/s of the whole mimic loop (read, decode, DON, PD
control, physics, rendering the robot, writing the side-by-side video and the CSV)
beside plain OpenCV decoding of the same file in the same run (the reference: no loop
can read the footage faster), the processing latency, DON's trust factor, and the
estimate's behaviour: where it stands before the first motion, its range, how often it
leaves the joint range, and how far it jumps between frames. There is no ground truth
for these clips; `--frames DIR` writes a few side-by-side frames as PNG to look at.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import statistics
import time
from pathlib import Path

import cv2
import numpy as np

from imimic_gym.bench import machine
from imimic_gym.clips.video import stream_video
from imimic_gym.mimic import run_mimic

REALDATA = Path(__file__).resolve().parent.parent.parent / "shared" / "realdata" / "videos"

# (clip, setting name, mimic options). "defaults": what a user gets with no flags (the
# reference link down the image, the paper's 120-degree range around it, DON finds the
# pivot). "elbow given": the geometry a user would read off the first frame.
SETTINGS = (
    ("ta_chi.mp4", "defaults", {}),
    ("slp_test_video.mp4", "defaults", {}),
    ("slp_test_video.mp4", "elbow given", {
        "pivot": (80.0, 700.0), "reference_direction": 0.0,
        "joint_range": (0.0, math.radians(120.0))}),
)


def decode_frames_per_s(path: Path, repeats: int = 3) -> float:
    """Plain OpenCV decoding of ``path`` (BGR, nothing else), median of ``repeats``."""
    rates = []
    for _ in range(repeats):
        capture = cv2.VideoCapture(str(path))
        try:
            start, count = time.perf_counter(), 0
            while capture.read()[0]:
                count += 1
            rates.append(count / (time.perf_counter() - start))
        finally:
            capture.release()
    return statistics.median(rates)


def estimate_behaviour(csv_path: Path, joint_range: tuple[float, float]) -> dict[str, float]:
    """What the estimate did, from mimic.csv: degrees and frames."""
    with csv_path.open(newline="") as f:
        rows = list(csv.DictReader(f))
    angle = np.degrees([float(r["angle_rad"]) for r in rows])
    omega = np.array([float(r["omega_rad_s"]) for r in rows])
    moving = np.flatnonzero(omega != 0)
    low, high = np.degrees(joint_range)
    jumps = np.abs((np.diff(angle) + 180) % 360 - 180)
    return {
        "first_tracked_frame": int(moving[0]) if moving.size else -1,
        "angle_min_deg": float(angle.min()),
        "angle_max_deg": float(angle.max()),
        "outside_joint_range_fraction": float(np.mean((angle < low - 1) | (angle > high + 1))),
        "median_jump_deg": float(np.median(jumps)) if jumps.size else 0.0,
        "max_jump_deg": float(jumps.max()) if jumps.size else 0.0,
    }


def save_frames(video: Path, folder: Path, stem: str, count: int = 6) -> None:
    capture = cv2.VideoCapture(str(video))
    frames = []
    try:
        while (frame := capture.read()[1]) is not None:
            frames.append(frame)
    finally:
        capture.release()
    folder.mkdir(parents=True, exist_ok=True)
    for index in np.linspace(0, len(frames) - 1, count).astype(int):
        cv2.imwrite(str(folder / f"{stem}_{index:04d}.png"), frames[index])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--json", default=None, help="write the results to this file")
    parser.add_argument("--out", default="real_footage_out",
                        help="folder for the mimic outputs (not committed)")
    parser.add_argument("--frames", default=None, metavar="DIR",
                        help="also write a few side-by-side frames per run as PNG")
    args = parser.parse_args()
    if not REALDATA.is_dir():
        print(f"real footage not found at {REALDATA}: nothing measured, nothing written "
              "(the clips are evaluation material outside the repository)")
        return
    print(f"reading real footage from {REALDATA} (evaluation only)")
    rows = []
    for name, setting, options in SETTINGS:
        path = REALDATA / name
        if not path.exists():
            print(f"  {name}: missing, skipped")
            continue
        joint_range = options.get("joint_range", (-math.pi / 3, math.pi / 3))
        clip = stream_video(path, reference_direction=options.get("reference_direction",
                                                                   -math.pi / 2),
                            joint_ranges=[joint_range])
        out = Path(args.out) / f"{path.stem}-{setting.replace(' ', '-')}"
        params = {"pivot": options["pivot"]} if "pivot" in options else {}
        decode = decode_frames_per_s(path)
        summary = run_mimic(clip, out, estimator_params=params, progress=False)
        row = {
            "clip": name,
            "setting": setting,
            "options": {k: (list(v) if isinstance(v, tuple) else v) for k, v in options.items()},
            "resolution": f"{clip.width}x{clip.height}",
            "frames": summary["frames"],
            "video_fps": summary["video_fps"],
            "mimic_frames_per_s": summary["frames_per_s"],
            "decode_frames_per_s": decode,
            "ratio_to_decode": summary["frames_per_s"] / decode,
            "realtime_factor": summary["frames_per_s"] / summary["video_fps"],
            "latency_ms_median": summary["latency_ms_median"],
            "latency_ms_p95": summary["latency_ms_p95"],
            "mean_trust": summary["mean_trust"],
            **estimate_behaviour(out / "mimic.csv", joint_range),
        }
        rows.append(row)
        print(f"  {name:20s} {setting:12s} mimic {row['mimic_frames_per_s']:6.1f} frames/s, "
              f"decode {decode:7.1f} (ratio {row['ratio_to_decode']:.3f}), "
              f"{row['realtime_factor']:.1f}x real time, latency {row['latency_ms_median']:.1f} "
              f"ms, eta {row['mean_trust']:.2f}, angle {row['angle_min_deg']:.0f}.."
              f"{row['angle_max_deg']:.0f} deg", flush=True)
        if args.frames:
            save_frames(out / "mimic.mp4", Path(args.frames),
                        f"{path.stem}-{setting.replace(' ', '-')}")
    if args.json:
        Path(args.json).write_text(json.dumps(
            {"machine": machine(), "source": "../shared/realdata/videos", "rows": rows},
            indent=2) + "\n")
        print(f"wrote {args.json}")


if __name__ == "__main__":
    main()
