"""Estimator-only evaluation over clips with truth: `imimic eval` without a controller.

Any registered estimator (`estimators.registry`) that reads pixels runs over whole clips,
without an env, from the same `EstimatorContext` an env would publish (no robot model:
torques are not scored here).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from imimic_gym.clips.cache import load_clip
from imimic_gym.clips.scenarios import ClipSpec, get_scenario
from imimic_gym.clips.types import Clip
from imimic_gym.envs.imitate_video import MODALITIES, depth_to_frame
from imimic_gym.estimators.registry import build_estimator, get_estimator
from imimic_gym.estimators.types import EstimatorContext
from imimic_gym.metrics import OCCLUDED, angle_rmse_deg, lag_frames

__all__ = ["WARM_UP_S", "clip_context", "evaluate_estimator"]

WARM_UP_S = 0.5  # frame-differencing estimators see nothing until the arm has moved
PREDICTION_ON = 0.3  # the trust threshold used for "with the prediction layer"
PREDICTING = ("don", "don-paper")  # estimators with a prediction layer to score


def clip_context(spec: ClipSpec, clip: Clip, modality: str = "rgb") -> EstimatorContext:
    """The context of a scenario's clip as `ImitateVideoEnv.estimator_context` gives it,
    less the robot model (no torques) and the truth (the oracle is not scored here)."""
    return EstimatorContext(
        fps=float(clip.fps), link_parents=tuple(spec.link_parents),
        joint_ranges=tuple((float(lo), float(hi)) for lo, hi in spec.joint_ranges),
        reference_direction=float(clip.meta.get("reference_direction",
                                                spec.reference_direction)),
        modality=modality, demonstrator=spec.demonstrator)


def evaluate_estimator(scenario: str, estimator: str, episodes: int = 3,
                       first_seed: int = 1000, modality: str = "rgb") -> dict[str, Any]:
    """Run ``estimator`` over ``episodes`` held-out clips of ``scenario`` (seeds from
    ``first_seed``; training and tests use seeds below 1000) and score it against the truth.

    ``modality="depth"`` feeds the estimator the clip's depth video as grey frames, near =
    bright, exactly as ``ImitateVideo-v0(modality="depth")`` shows it.

    Per episode: angle RMSE (deg) over all frames and after ``WARM_UP_S`` (and, with
    several links, after it per joint: ``rmse_deg_settled_q1`` ...), lag (frames,
    cross-correlation peak, after warm-up), mean trust eta, and where the clip has
    occluded frames (over 10% of the moving links hidden), the mean eta on those frames
    and on the others, and the RMSE on them with the prediction layer off and on (DON
    only, with or without its appearance layer).
    """
    if modality not in MODALITIES:
        raise ValueError(f"unknown modality {modality!r}; expected one of {MODALITIES}")
    spec = get_scenario(scenario)
    if get_estimator(estimator).needs_truth:
        raise ValueError(f"estimator {estimator!r} is the truth itself: score it with a "
                         "controller")
    rows = []
    for seed in range(first_seed, first_seed + episodes):
        clip = load_clip(spec.replace(seed=seed), progress=False)
        frames = clip.frames if modality == "rgb" else depth_to_frame(clip.depth)
        truth = clip.truth.angles
        warm = round(WARM_UP_S * clip.fps)
        context = clip_context(spec, clip, modality)
        estimates = run_estimator(build_estimator(estimator, context), frames)
        angles = np.array([e.angles for e in estimates])
        row: dict[str, Any] = {
            "seed": seed,
            "rmse_deg": angle_rmse_deg(angles, truth),
            "rmse_deg_settled": angle_rmse_deg(angles[warm:], truth[warm:]),
            "lag_frames": lag_frames(truth[warm:], angles[warm:]),
            "mean_trust": float(np.mean([e.trust for e in estimates])),
        }
        if spec.n_links > 1:
            for joint in range(spec.n_links):
                row[f"rmse_deg_settled_q{joint + 1}"] = angle_rmse_deg(angles[warm:, joint],
                                                                      truth[warm:, joint])
        occluded = clip.truth.occlusion > OCCLUDED
        row["occluded_frames"] = int(occluded.sum())
        if occluded.any() and not occluded.all():
            trust = np.array([e.trust for e in estimates])
            row["mean_trust_occluded"] = float(trust[occluded].mean())
            row["mean_trust_clear"] = float(trust[~occluded].mean())
        if occluded.any() and estimator in PREDICTING and spec.n_links == 1:
            on = run_estimator(build_estimator(estimator, context,
                                               trust_threshold=PREDICTION_ON), frames)
            with_prediction = np.array([e.angles for e in on])
            row["rmse_occluded_deg_prediction_off"] = angle_rmse_deg(angles[occluded],
                                                                     truth[occluded])
            row["rmse_occluded_deg_prediction_on"] = angle_rmse_deg(with_prediction[occluded],
                                                                    truth[occluded])
        rows.append(row)
    # Occlusion figures exist only for clips with occluded frames: average where present.
    keys = dict.fromkeys(key for row in rows for key in row if key != "seed")
    summary = {key: float(np.mean([r[key] for r in rows if key in r])) for key in keys}
    return {"scenario": scenario, "estimator": estimator, "modality": modality,
            "episodes": episodes,
            "first_seed": first_seed, "warm_up_s": WARM_UP_S, "mean": summary, "rows": rows}


def run_estimator(estimator: Any, frames: Any) -> list:
    """Every estimate of ``estimator`` over ``frames`` (T, H, W, 3) uint8, from a reset."""
    estimator.reset()
    return [estimator.update(frame) for frame in frames]
