"""Estimator-only evaluation over clips with truth: `imimic eval` without a controller.

Any registered estimator (`estimators.registry`) that reads pixels runs over whole clips,
without an env, from the same `EstimatorContext` an env would publish (no robot model:
torques are not scored here).
"""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from imimic_gym.clips.cache import load_clip
from imimic_gym.clips.scenarios import ClipSpec, get_scenario
from imimic_gym.clips.types import MODALITIES, Clip, depth_to_frame
from imimic_gym.estimators.registry import (
    ESTIMATORS,
    UnsupportedClipError,
    build_estimator,
    get_estimator,
)
from imimic_gym.estimators.types import EstimatorContext
from imimic_gym.kinematics import wrap_angle
from imimic_gym.metrics import OCCLUDED, angle_rmse_deg, lag_frames

__all__ = ["WARM_UP_S", "cannot_score", "clip_context", "evaluate_clip", "evaluate_estimator",
           "evaluate_photos", "summarise_estimator"]

WARM_UP_S = 0.5  # frame-differencing estimators see nothing until the arm has moved
PREDICTION_ON = 0.3  # the trust threshold used for "with the prediction layer"
PREDICTING = ("don", "don-paper")  # estimators with a prediction layer to score


def clip_context(spec: ClipSpec, clip: Clip, modality: str = "rgb") -> EstimatorContext:
    """The context of a scenario's clip as `ImitateVideoEnv.estimator_context` gives it,
    less the robot model (no torques) and the truth (the oracle is not scored here)."""
    return replace(_spec_context(spec, modality), fps=float(clip.fps),
                   reference_direction=float(clip.meta.get("reference_direction",
                                                           spec.reference_direction)))


def _spec_context(spec: ClipSpec, modality: str) -> EstimatorContext:
    """`clip_context` as the scenario's settings give it, before its clip is rendered (a
    spatial scenario's camera comes with the clip)."""
    return EstimatorContext(
        fps=float(spec.fps), link_parents=tuple(spec.link_parents),
        joint_ranges=tuple((float(lo), float(hi)) for lo, hi in spec.joint_ranges),
        reference_direction=float(spec.reference_direction), modality=modality,
        demonstrator=spec.demonstrator, spatial=spec.spatial)


def cannot_score(scenario: str, estimator: str, modality: str = "rgb",
                 controlled: bool = False) -> str | None:
    """Why ``estimator`` cannot be scored on clips of ``scenario``, known before any clip
    is rendered, or None if it can: alone (`evaluate_clip`) or, ``controlled``, driving
    a controller (the tracking suite, where the env gives the oracle the truth). Alone,
    an estimator that is the truth itself has nothing to be scored against; otherwise
    `EstimatorEntry.unsupported` says. Unknown names raise ValueError."""
    entry = get_estimator(estimator)
    if entry.needs_truth:
        return None if controlled else (f"estimator {estimator!r} is the truth itself: "
                                        "score it with a controller")
    return entry.unsupported(_spec_context(get_scenario(scenario), modality))


def evaluate_estimator(scenario: str, estimator: str, episodes: int = 3,
                       first_seed: int = 1000, modality: str = "rgb",
                       frames: int | None = None) -> dict[str, Any]:
    """Run ``estimator`` over ``episodes`` held-out clips of ``scenario`` (seeds from
    ``first_seed``; training and tests use seeds below 1000) and score it against the truth
    (`evaluate_clip` per seed, `summarise_estimator` over them)."""
    rows = [evaluate_clip(scenario, estimator, seed, modality, frames)
            for seed in range(first_seed, first_seed + episodes)]
    return summarise_estimator(scenario, estimator, modality, rows)


def evaluate_clip(scenario: str, estimator: str, seed: int, modality: str = "rgb",
                  frames: int | None = None,
                  params: dict[str, Any] | None = None) -> dict[str, Any]:
    """Score ``estimator`` (built with ``params``, e.g. the CNN's ``checkpoint``) on the
    clip of ``scenario`` with this ``seed`` (``frames`` long: default the scenario's)
    against its truth: one row of `evaluate_estimator`.

    ``modality="depth"`` feeds the estimator the clip's depth video as grey frames, near =
    bright, exactly as ``ImitateVideo-v0(modality="depth")`` shows it.

    The row: angle RMSE (deg) over all frames and after ``WARM_UP_S`` (and, with several
    links, after it per joint: ``rmse_deg_settled_q1`` ...), lag (frames, cross-correlation
    peak, after warm-up), mean trust eta, and where the clip has occluded frames (over 10%
    of the moving links hidden), the mean eta on those frames and on the others, and the
    RMSE on them with the prediction layer off and on (DON only, with or without its
    appearance layer). The figures after warm-up are None for a clip that ends within it.

    Raises `UnsupportedClipError` (a ValueError) where `cannot_score` gives a reason.
    """
    if modality not in MODALITIES:
        raise ValueError(f"unknown modality {modality!r}; expected one of {MODALITIES}")
    why = cannot_score(scenario, estimator, modality)
    if why:
        raise UnsupportedClipError(why)
    spec = get_scenario(scenario, **({"n_frames": frames} if frames else {}))
    clip = load_clip(spec.replace(seed=seed), progress=False)
    assert clip.truth is not None and clip.depth is not None  # a rendered clip has both
    if spec.spatial:
        return _evaluate_spatial(spec, clip, estimator, seed, modality)
    images = clip.frames if modality == "rgb" else depth_to_frame(clip.depth)
    truth = clip.truth.angles
    warm = round(WARM_UP_S * clip.fps)
    context = clip_context(spec, clip, modality)
    estimates = run_estimator(build_estimator(estimator, context, **(params or {})), images)
    angles = np.array([e.angles for e in estimates])
    row: dict[str, Any] = {
        "seed": seed,
        "rmse_deg": angle_rmse_deg(angles, truth),
        **_settled(angles[warm:], truth[warm:], spec.n_links),
        "mean_trust": float(np.mean([e.trust for e in estimates])),
    }
    occluded = clip.truth.occlusion > OCCLUDED
    row["occluded_frames"] = int(occluded.sum())
    if occluded.any() and not occluded.all():
        trust = np.array([e.trust for e in estimates])
        row["mean_trust_occluded"] = float(trust[occluded].mean())
        row["mean_trust_clear"] = float(trust[~occluded].mean())
    if occluded.any() and estimator in PREDICTING and spec.n_links == 1:
        on = run_estimator(build_estimator(estimator, context,
                                           trust_threshold=PREDICTION_ON), images)
        with_prediction = np.array([e.angles for e in on])
        row["rmse_occluded_deg_prediction_off"] = angle_rmse_deg(angles[occluded],
                                                                 truth[occluded])
        row["rmse_occluded_deg_prediction_on"] = angle_rmse_deg(with_prediction[occluded],
                                                                truth[occluded])
    return row


def _evaluate_spatial(spec: ClipSpec, clip: Clip, estimator: str, seed: int,
                      modality: str) -> dict[str, Any]:
    """`evaluate_clip`'s row for a spatial estimator on a spatial clip: the arm it reads in
    3-D against the clip's truth (`metrics.spatial_metrics`: elbow-flexion RMSE, the
    forearm's and upper arm's direction errors, median and 95th percentile), frames
    without a reading left out and counted. Each RGB frame comes with its metric depth
    image, as from an RGB-D camera: the estimators that read depth (``pose3d-depth``) use
    it, the others do not. And the 2-D reading under it (the pose model's keypoints):
    ``arm_found``, the share of frames where it reads the moving arm (the clip's side,
    with trust), and ``elbow_2d_rmse_deg``, the elbow's angle in the image on those
    frames against the truth's pixels (``elbow_2d_across_rmse_deg``: on those where the
    upper arm and forearm both lie within 45 degrees of the image plane)."""
    from imimic_gym.estimators.registry import build_spatial_estimator
    from imimic_gym.metrics import spatial_metrics
    from imimic_gym.spatial.truth import arm_poses, clip_intrinsics

    assert clip.depth is not None  # rendered
    context = replace(clip_context(spec, clip, modality), intrinsics=clip_intrinsics(clip))
    reader = build_spatial_estimator(estimator, context)
    try:
        reader.reset()
        poses = [reader.update(frame, depth) for frame, depth in zip(clip.frames, clip.depth,
                                                                     strict=True)]
    finally:
        _close(reader)
    truth = arm_poses(clip)

    def stack(which: list, what: str) -> np.ndarray:
        return np.array([getattr(pose, what) for pose in which])

    read = np.array([pose.trust > 0 for pose in poses])
    found = read & np.array([pose.side == clip.meta["arm_side"] for pose in poses])
    elbow_2d = np.array([wrap_angle(p.to_planar(1)[0] - t.to_planar(1)[0])
                         for p, t in zip(poses, truth, strict=True)])
    # Both segments within 45 degrees of the image plane: elsewhere a foreshortened
    # segment's image direction turns by tens of degrees for a pixel.
    across = found & np.array([max(abs(t.upper_arm[2]), abs(t.forearm[2])) < np.sqrt(0.5)
                               for t in truth])

    def rmse(errors: np.ndarray) -> float | None:
        return float(np.degrees(np.sqrt(np.mean(errors**2)))) if errors.size else None

    return {"seed": seed,
            "arm_found": float(found.mean()),
            "elbow_2d_rmse_deg": rmse(elbow_2d[found]),
            "elbow_2d_across_rmse_deg": rmse(elbow_2d[across]),
            **spatial_metrics(stack(poses, "upper_arm"), stack(poses, "forearm"),
                              stack(poses, "elbow_flexion"), stack(truth, "upper_arm"),
                              stack(truth, "forearm"), stack(truth, "elbow_flexion"), read),
            "coverage": float(read.mean())}


def _settled(angles: np.ndarray, truth: np.ndarray, n_links: int) -> dict[str, Any]:
    """The scores after warm-up, from the estimated and true angles (T, n_links) rad of
    the frames after it: RMSE (deg; with several links also per joint) and lag (frames);
    each None when the clip ends within the warm-up (T = 0)."""
    joints = [f"rmse_deg_settled_q{joint + 1}" for joint in range(n_links)] if n_links > 1 else []
    if len(truth) == 0:
        return dict.fromkeys(["rmse_deg_settled", "lag_frames", *joints])
    return {"rmse_deg_settled": angle_rmse_deg(angles, truth),
            "lag_frames": lag_frames(truth, angles),
            **{key: angle_rmse_deg(angles[:, joint], truth[:, joint])
               for joint, key in enumerate(joints)}}


def summarise_estimator(scenario: str, estimator: str, modality: str,
                        rows: list[dict[str, Any]]) -> dict[str, Any]:
    """`evaluate_estimator`'s result from its per-seed rows (in seed order): every
    metric's mean, over the clips that have it (occlusion figures exist only for clips
    with occluded frames); None where no clip has it (the settled figures of clips that
    end within the warm-up)."""
    keys = dict.fromkeys(key for row in rows for key in row if key != "seed")
    summary = {}
    for key in keys:
        values = [r[key] for r in rows if r.get(key) is not None]
        summary[key] = float(np.mean(values)) if values else None
    return {"scenario": scenario, "estimator": estimator, "modality": modality,
            "episodes": len(rows), "first_seed": rows[0]["seed"] if rows else None,
            "warm_up_s": WARM_UP_S, "mean": summary, "rows": rows}


def run_estimator(estimator: Any, frames: Any) -> list:
    """Every estimate of ``estimator`` over ``frames`` (T, H, W, 3) uint8, from a reset.
    The estimator is closed at the end (`_close`)."""
    try:
        estimator.reset()
        return [estimator.update(frame) for frame in frames]
    finally:
        _close(estimator)


def _close(estimator: Any) -> None:
    """The estimator's ``close``, if it has one. A pose model's graph that is not closed
    keeps its native memory (about 100 MB) to the end of the process: a sweep that
    scores clip after clip in one process ran out of 24 GB."""
    close = getattr(estimator, "close", None)
    if callable(close):
        close()


def evaluate_photos(annotations: str | Path, images: str | Path, estimator: str,
                    **params: Any) -> dict[str, Any]:
    """Score ``estimator`` (one that reads single frames: the registry's ``photos``) on
    annotated photos: the arm `clips.annotations.read_annotations` takes from each (the
    largest labelled person's, their left where complete, else their right).

    Each photo is read from a fresh start (``reset``), as a two-link arm so that the
    estimate's keypoints are shoulder, elbow and wrist; an estimator that can choose the
    arm (``arm``) is told the labelled side, and the pose model scores every position it
    gives (``min_confidence=0``, unless ``params`` say otherwise). A photo where it gives
    no keypoints counts as wrong.

    Returns PCP@0.5 of the upper and lower arm and the median elbow-angle error (deg,
    the forearm from the upper arm, over photos with keypoints), each with its 95%
    bootstrap interval, and one row per photo.
    """
    import cv2

    from imimic_gym.clips.annotations import image_path, read_annotations
    from imimic_gym.estimators.pose.planar import human_joint_ranges
    from imimic_gym.kinematics import keypoints_to_angles, wrap_angle
    from imimic_gym.metrics import pcp, with_interval

    entry = get_estimator(estimator)
    if not entry.photos:
        raise ValueError(f"estimator {estimator!r} reads motion between frames and cannot "
                         "score single photos; use one that reads each frame alone ("
                         f"{', '.join(n for n, e in ESTIMATORS.items() if e.photos)})")
    arms = read_annotations(annotations)
    if not arms:
        raise ValueError(f"{annotations}: no photo has a complete labelled arm")
    context = EstimatorContext(fps=30.0, link_parents=(-1, 0),
                               joint_ranges=human_joint_ranges(2),
                               reference_direction=-math.pi / 2)
    if "min_confidence" in entry.params:
        params = {"min_confidence": 0.0, **params}
    rows, readers = [], {}  # one estimator per arm side
    for arm in arms:
        path = image_path(arm, images)
        picture = cv2.imread(str(path))
        if picture is None:
            raise ValueError(f"{path}: not an image OpenCV can read")
        side = arm.side or "left" if "arm" in entry.params else None
        if side not in readers:
            chosen = {"arm": side} if side is not None else {}
            readers[side] = build_estimator(estimator, context, **{**params, **chosen})
        reader = readers[side]
        reader.reset()
        estimate = reader.update(cv2.cvtColor(picture, cv2.COLOR_BGR2RGB))
        found = estimate.keypoints is not None and estimate.keypoints.shape == (3, 2)
        truth = arm.keypoints.astype(np.float64)[None]
        row: dict[str, Any] = {"photo": arm.file_name, "found": bool(found)}
        if found:
            predicted = np.asarray(estimate.keypoints, np.float64)[None]
            row["upper_correct"] = bool(pcp(predicted, truth, (0, 1)))
            row["lower_correct"] = bool(pcp(predicted, truth, (1, 2)))
            error = wrap_angle(keypoints_to_angles(predicted, 1) - keypoints_to_angles(truth, 1))
            row["elbow_error_deg"] = float(abs(math.degrees(error[0, 0])))
        else:
            row.update(upper_correct=False, lower_correct=False, elbow_error_deg=None)
        rows.append(row)

    errors = [r["elbow_error_deg"] for r in rows if r["found"]]
    return {
        "estimator": estimator, "annotations": str(annotations), "photos": len(rows),
        "found": sum(r["found"] for r in rows),
        "pcp_upper": with_interval([float(r["upper_correct"]) for r in rows]),
        "pcp_lower": with_interval([float(r["lower_correct"]) for r in rows]),
        "elbow_error_deg_median": with_interval(errors, np.median),
        "rows": rows,
    }
