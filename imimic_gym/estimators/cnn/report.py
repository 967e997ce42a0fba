"""Scoring keypoint predictions the paper's way: PCP@0.5 tables beside the paper's.

The paper (§6, Tables 2 and 3) reports PCP@0.5 of the upper arm (shoulder-elbow) and the
lower arm (elbow-wrist) on its first 20 and 40 test images, against DeepPose's three
stages (numbers quoted by the paper from Toshev & Szegedy). We report the same subsets,
the full test set, the mean pixel error and the joint-angle error.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from imimic_gym.kinematics import keypoints_to_angles, wrap_angle
from imimic_gym.metrics import pcp

__all__ = ["PAPER_PCP", "format_pcp_tables", "pcp_report"]

# The paper's Tables 2 (20 images) and 3 (40 images): (upper arm, lower arm) PCP@0.5.
PAPER_PCP: dict[int, dict[str, tuple[float, float]]] = {
    20: {"DeepPose 1st stage": (0.5, 0.27), "DeepPose 2nd stage": (0.56, 0.35),
         "DeepPose 3rd stage": (0.56, 0.35), "CNN": (0.40, 0.1),
         "CNN + refiner": (0.7, 0.35)},
    40: {"DeepPose 1st stage": (0.5, 0.27), "DeepPose 2nd stage": (0.56, 0.35),
         "DeepPose 3rd stage": (0.56, 0.35), "CNN": (0.25, 0.125),
         "CNN + refiner": (0.566, 0.275)},
}
UPPER, LOWER = (0, 1), (1, 2)


def pcp_report(predicted: np.ndarray, truth: np.ndarray, n_links: int) -> dict[str, Any]:
    """PCP@0.5 of upper and lower arm on the first 20, the first 40 and all images, the
    mean keypoint error (pixels) and the mean absolute joint-angle error (degrees).

    Args:
        predicted, truth: (N, 3, 2) pixel keypoints (shoulder, elbow, wrist).
        n_links: which joint angles to score (1: the elbow; 2: shoulder and elbow).
    """
    predicted, truth = np.asarray(predicted, np.float64), np.asarray(truth, np.float64)
    subsets = {"20": 20, "40": 40, "all": len(truth)}
    report: dict[str, Any] = {"n_images": len(truth)}
    for name, n in subsets.items():
        if n <= len(truth):
            report[f"pcp_{name}"] = {"upper": pcp(predicted[:n], truth[:n], UPPER),
                                     "lower": pcp(predicted[:n], truth[:n], LOWER)}
    report["mean_pixel_error"] = float(np.mean(np.linalg.norm(predicted - truth, axis=2)))
    error = wrap_angle(keypoints_to_angles(predicted, n_links)
                       - keypoints_to_angles(truth, n_links))
    report["angle_error_deg"] = float(np.degrees(np.mean(np.abs(error))))
    return report


def format_pcp_tables(cnn: dict[str, Any], refined: dict[str, Any], title: str = "",
                      cnn_label: str = "CNN") -> str:
    """The paper's Tables 2 and 3 with our CNN (labelled ``cnn_label``) and CNN + refiner
    rows beside its rows, then the full test set and the pixel and angle errors."""
    lines = [title] if title else []
    for n in (20, 40):
        key = f"pcp_{n}"
        if key not in cnn:
            continue
        lines += [f"PCP@0.5 on the first {n} test images   upper arm  lower arm",
                  *(f"  paper: {name:28s} {u:9.3f}  {low:9.3f}"
                    for name, (u, low) in PAPER_PCP[n].items()),
                  f"  ours:  {cnn_label:28s} {cnn[key]['upper']:9.3f}  {cnn[key]['lower']:9.3f}",
                  f"  ours:  {'CNN + refiner':28s} {refined[key]['upper']:9.3f}  "
                  f"{refined[key]['lower']:9.3f}"]
    n = cnn["n_images"]
    lines += [f"All {n} test images                      upper arm  lower arm  px error  "
              "angle error (deg)"]
    for name, r in ((cnn_label, cnn), ("CNN + refiner", refined)):
        lines.append(f"  ours:  {name:28s} {r['pcp_all']['upper']:9.3f}  "
                     f"{r['pcp_all']['lower']:9.3f}  {r['mean_pixel_error']:8.2f}  "
                     f"{r['angle_error_deg']:8.2f}")
    return "\n".join(lines)
