"""Estimator-only evaluation over held-out clips: `imimic eval` (first version)."""

from __future__ import annotations

import functools
from typing import Any

import numpy as np

from imimic_gym.clips.cache import load_clip
from imimic_gym.clips.scenarios import ClipSpec, get_scenario
from imimic_gym.envs.imitate_video import MODALITIES, depth_to_frame
from imimic_gym.estimators.don import gaussian_for
from imimic_gym.estimators.don_links import LinkedDON
from imimic_gym.metrics import OCCLUDED, angle_rmse_deg, lag_frames

__all__ = ["ESTIMATORS", "WARM_UP_S", "evaluate_estimator", "make_estimator", "make_linked_don"]

# "don-paper" is DON with the paper's layers alone (``appearance=False``).
ESTIMATORS = ("don", "don-paper", "mog2", "camshift", "cnn")
WARM_UP_S = 0.5  # frame-differencing estimators see nothing until the arm has moved
PREDICTION_ON = 0.3  # the trust threshold used for "with the prediction layer"


def make_estimator(name: str, clip_meta: dict[str, Any], fps: float,
                   joint_range: tuple[float, float], **params: Any):
    """An estimator set up for a clip: its fps, reference direction and joint range
    (the CNN takes the number of links instead: it needs no range)."""
    from imimic_gym.estimators.baselines import CamShiftEstimator, MOG2Estimator
    from imimic_gym.estimators.don import DON

    if name == "cnn":
        from imimic_gym.estimators.cnn import CNNEstimator

        return CNNEstimator(n_links=int(clip_meta["n_links"]), fps=fps,
                            reference_direction=float(clip_meta["reference_direction"]),
                            **params)

    classes = {"don": DON, "don-paper": functools.partial(DON, appearance=False),
               "mog2": MOG2Estimator, "camshift": CamShiftEstimator}
    if name not in classes:
        raise ValueError(f"unknown estimator {name!r}; expected one of {ESTIMATORS}")
    return classes[name](fps=fps, reference_direction=float(clip_meta["reference_direction"]),
                         joint_range=joint_range, **params)


def make_linked_don(spec: ClipSpec, fps: float, **params: Any) -> LinkedDON:
    """DON for a scenario with several moving links (`LinkedDON`), set up from its spec:
    the tree of links, the joint ranges and the reference direction."""
    return LinkedDON(spec.link_parents, spec.joint_ranges, fps=fps,
                     reference_direction=spec.reference_direction, **params)


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
    if spec.n_links != 1 and estimator not in ("don", "don-paper"):
        raise ValueError(f"the estimators other than DON follow one moving link; "
                         f"{scenario!r} has {spec.n_links}")
    # DON smooths depth video, not colour, as `DONObservation` does.
    smoothing = ({"gaussian": gaussian_for(modality)}
                 if estimator in ("don", "don-paper") else {})
    rows = []
    for seed in range(first_seed, first_seed + episodes):
        clip = load_clip(spec.replace(seed=seed), progress=False)
        frames = clip.frames if modality == "rgb" else depth_to_frame(clip.depth)
        truth = clip.truth.angles
        warm = round(WARM_UP_S * clip.fps)
        if spec.n_links == 1:
            est = make_estimator(estimator, clip.meta, clip.fps, spec.joint_ranges[0],
                                 **smoothing)
        else:
            est = make_linked_don(spec, clip.fps, appearance=estimator == "don")
        estimates = est.run(frames)
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
        if occluded.any() and estimator in ("don", "don-paper"):
            on = make_estimator(estimator, clip.meta, clip.fps, spec.joint_ranges[0],
                                trust_threshold=PREDICTION_ON, **smoothing).run(frames)
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
