"""Suite ``real``: how the estimators do on real people.

1. Photos: the 48 annotated COCO photos of ../shared/realdata/coco_mini. Per estimator
   that reads a single frame (the pose model, the shipped CNNs): PCP@0.5 of the upper
   and lower arm of the largest labelled person's labelled arm, and the elbow angle's
   error (the forearm from the upper arm, deg), with 95% bootstrap intervals over photos
   and the worst photos. A photo where the pose model finds nobody counts as wrong.
2. Videos: the clips of ../shared/realdata/videos (no truth). The pose model on every
   frame is the reference where it is confident; per estimator, as `imimic mimic` sets
   it up with no flags: the angle's correlation with the reference and its RMSE after
   removing the mean offset, on the reference's confident frames; how often it gives an
   estimate there and anywhere (trust > 0); its seconds per frame as a ratio to OpenCV
   decoding the same file, measured in the same run.
3. 1080p: one clip upscaled and letterboxed to 1920x1080 and encoded as H.264 (libx264
   through imageio-ffmpeg): decode, the pose model and pose-seeded DON per frame, and
   `imimic mimic`'s frames/s on it.
4. Rendered clips: the pose model on our renders of a person (seeds 6000-6029, a pool no
   choice has touched), its angle error against exact truth where it finds the arm,
   beside DON's and the CNN's on the same frames.
5. A CNN for one camera: each video labelled by the pose model (`imimic label`), the CNN
   trained on the first 70% of its labelled frames and tested on the last 30%.
6. The CNN beyond our renderer: a randomised synthetic set (`make_dataset.py
   --randomise`: clothing, skin, backdrop, light, camera height, tilt, distance and
   place), the CNN trained on it and on it plus every pose-labelled frame of the real
   videos (fixed seeds, in a temporary folder), scored on the photos of part 1 beside
   the shipped CNNs.

7. The env on real footage: `ImitateVideo-v0(clip=VIDEO, annotations="pose")` per
   video, one and two links, the oracle controller's RMSE and largest error against the
   pose model's labels on the frames that have one (`has_truth`).

Evaluation only: the real material is read in place, never copied into the repository,
and nothing trained on it is kept. Without it, parts 1-3 and 5-7 say so and only part 4
runs.
"""

from __future__ import annotations

import math
import statistics
import subprocess
import tempfile
import time
from pathlib import Path
from typing import Any

import cv2
import numpy as np
from suites.pool import work_folder

from imimic_gym.bench import machine
from imimic_gym.clips.cache import load_clip
from imimic_gym.clips.scenarios import get_scenario
from imimic_gym.clips.video import VideoReader, stream_video
from imimic_gym.estimators.pose.planar import human_joint_ranges
from imimic_gym.estimators.registry import build_estimator, get_estimator
from imimic_gym.estimators.types import EstimatorContext
from imimic_gym.evaluation import WARM_UP_S, clip_context, evaluate_photos, run_estimator
from imimic_gym.kinematics import wrap_angle
from imimic_gym.metrics import with_interval

REALDATA = Path(__file__).resolve().parents[3] / "shared" / "realdata"
VIDEO_ESTIMATORS = ("pose", "pose-don", "don", "don-paper", "mog2", "camshift", "cnn")
RENDERED = ("default", "exp3-forearm-none", "exp3-forearm-low", "exp3-forearm-high")
RENDERED_SEEDS = tuple(range(6000, 6030))
WORST = 5
SOURCES = {"pose": "the pose model's frames", "don": "DON's turns",
           "rolled": "rolled on at the pose rate"}  # pose-don's `source`


# 1. Photos ----------------------------------------------------------------------------
COCO = REALDATA / "coco_mini"


def photo_annotations(quick: bool) -> Path:
    """The COCO photos' annotation file; with ``quick``, a copy with the first 8 only."""
    annotations = COCO / "person_keypoints.json"
    if quick:
        import json

        data = json.loads(annotations.read_text())
        keep = {image["id"] for image in data["images"][:8]}
        data["images"] = [i for i in data["images"] if i["id"] in keep]
        data["annotations"] = [a for a in data["annotations"] if a["image_id"] in keep]
        annotations = work_folder("imimic_photos_") / "few.json"
        annotations.write_text(json.dumps(data))
    return annotations


def photo_row(annotations: Path, name: str, estimator: str,
              **params: Any) -> tuple[dict[str, Any], int]:
    """`evaluation.evaluate_photos` of ``estimator`` as a row of the photo table (PCP,
    photos with keypoints, the median elbow error, the worst photos), and the number of
    photos."""
    result = evaluate_photos(annotations, COCO / "images", estimator, **params)
    worst = sorted(result["rows"], key=lambda r: -(r["elbow_error_deg"]
                                                    if r["found"] else 181.0))[:WORST]
    print(f"  photos {name:24s} PCP upper {result['pcp_upper']['value']:.2f} lower "
          f"{result['pcp_lower']['value']:.2f}", flush=True)
    return ({**{k: result[k] for k in ("pcp_upper", "pcp_lower", "found",
                                       "elbow_error_deg_median")},
             "worst": [{"photo": r["photo"], "elbow_error_deg": r["elbow_error_deg"]}
                       for r in worst]}, result["photos"])


def photos(quick: bool) -> dict[str, Any]:
    """`imimic eval --photos` for the pose model and each shipped CNN."""
    from imimic_gym.estimators.cnn.estimator import default_checkpoint

    annotations = photo_annotations(quick)
    runs = {"pose": {}, **{f"cnn (shipped, {links} link{'s' * (links > 1)})":
                           {"checkpoint": str(default_checkpoint(links))} for links in (1, 2)}}
    rows = {}
    for name, params in runs.items():
        rows[name], count = photo_row(annotations, name, name.split()[0], **params)
    return {"photos": count, "source": str(COCO), "rows": rows}


# 2. Videos ----------------------------------------------------------------------------
def decode_seconds_per_frame(path: Path, repeats: int = 3) -> float:
    """OpenCV decoding ``path`` (nothing else), seconds a frame, median of ``repeats``."""
    times = []
    for _ in range(repeats):
        capture = cv2.VideoCapture(str(path))
        try:
            start, count = time.perf_counter(), 0
            while capture.read()[0]:
                count += 1
            times.append((time.perf_counter() - start) / max(count, 1))
        finally:
            capture.release()
    return statistics.median(times)


def mimic_context(name: str, fps: float) -> EstimatorContext:
    """The context `imimic mimic` gives estimator ``name`` with no flags, one link."""
    ranges = (human_joint_ranges(1) if get_estimator(name).real_people
              else ((-math.pi / 3, math.pi / 3),))
    return EstimatorContext(fps=fps, link_parents=(-1,), joint_ranges=ranges,
                            reference_direction=-math.pi / 2)


def run_timed(name: str, frames: list[np.ndarray], fps: float) -> tuple[list, float, Any]:
    """Estimator ``name``'s estimates over ``frames``, its seconds a frame, and it."""
    estimator = build_estimator(name, mimic_context(name, fps))
    estimator.reset()
    estimates = [estimator.update(frames[0])]  # a model's one-off start is not per frame
    start = time.perf_counter()
    estimates += [estimator.update(frame) for frame in frames[1:]]
    return estimates, (time.perf_counter() - start) / max(len(frames) - 1, 1), estimator


def agreement(angles: np.ndarray, reference: np.ndarray) -> dict[str, float | None]:
    """Correlation and RMSE after the mean offset (deg) of two angle series (rad)."""
    if len(angles) < 3:
        return {"correlation": None, "rmse_after_offset_deg": None, "offset_deg": None}
    difference = wrap_angle(angles - reference)
    offset = math.atan2(np.mean(np.sin(difference)), np.mean(np.cos(difference)))
    rmse = math.degrees(math.sqrt(np.mean(wrap_angle(difference - offset) ** 2)))
    a, r = np.unwrap(angles), np.unwrap(reference)
    correlation = (float(np.corrcoef(a, r)[0, 1]) if np.std(a) > 0 and np.std(r) > 0
                   else None)
    return {"correlation": correlation, "rmse_after_offset_deg": rmse,
            "offset_deg": math.degrees(offset)}


def videos(quick: bool) -> dict[str, Any]:
    rows = []
    for path in sorted((REALDATA / "videos").glob("*.mp4")):
        reader = VideoReader(path)
        frames, fps = list(reader), float(reader.fps)
        frames = frames[: 40 if quick else None]
        decode = decode_seconds_per_frame(path)
        reference, _, _ = run_timed("pose", frames, fps)
        confident = np.array([e.trust > 0 for e in reference])
        ref_angles = np.array([e.angles[0] for e in reference])
        for name in VIDEO_ESTIMATORS:
            estimates, seconds, estimator = run_timed(name, frames, fps)
            angles = np.array([e.angles[0] for e in estimates])
            gives = np.array([e.trust > 0 for e in estimates])
            both = confident & gives
            row = {"video": path.name, "resolution": f"{frames[0].shape[1]}x{frames[0].shape[0]}",
                   "frames": len(frames), "estimator": name,
                   "reference_confident_frames": int(confident.sum()),
                   "estimate_where_reference_confident": (float(gives[confident].mean())
                                                          if confident.any() else None),
                   "no_output_fraction": float(1 - gives.mean()),
                   "seconds_per_frame": seconds, "decode_seconds_per_frame": decode,
                   "ratio_to_decode": seconds / decode,
                   **agreement(angles[both], ref_angles[both])}
            if hasattr(estimator, "pose_frames"):
                row["pose_frames"] = estimator.pose_frames
            rows.append(row)
            corr = row["correlation"]
            print(f"  {path.name:20s} {name:9s} corr {corr if corr is None else round(corr, 2)}"
                  f", rmse {row['rmse_after_offset_deg']}, covers "
                  f"{row['estimate_where_reference_confident']}, x{row['ratio_to_decode']:.1f} "
                  "decode", flush=True)
    return {"rows": rows}


# 3. 1080p -----------------------------------------------------------------------------
def make_1080p(source: Path, out: Path) -> Path:
    """``source`` scaled to 1080 rows, letterboxed to 1920x1080, H.264 (libx264, CRF 18)."""
    import imageio_ffmpeg

    subprocess.run([imageio_ffmpeg.get_ffmpeg_exe(), "-loglevel", "error", "-y", "-i",
                    str(source), "-vf", "scale=-2:1080,pad=1920:1080:(ow-iw)/2:0",
                    "-c:v", "libx264", "-crf", "18", "-pix_fmt", "yuv420p", str(out)],
                   check=True)
    return out


def hd(quick: bool) -> dict[str, Any]:
    from imimic_gym.mimic import run_mimic

    work = work_folder("imimic_real_")
    path = make_1080p(REALDATA / "videos" / "ta_chi.mp4", work / "ta_chi_1080p.mp4")
    decode = decode_seconds_per_frame(path)
    with VideoReader(path).open() as reader:
        fps = float(reader.fps)
    result: dict[str, Any] = {"clip": "ta_chi.mp4 at 1920x1080 (H.264, CRF 18)",
                              "decode_seconds_per_frame": decode}
    angles = {}
    for name in ("pose", "pose-don"):
        estimator = build_estimator(name, mimic_context(name, fps))
        estimator.reset()
        spent, estimates, sources = 0.0, [], []
        for i, frame in enumerate(VideoReader(path)):
            if quick and i >= 40:
                break
            start = time.perf_counter()
            estimates.append(estimator.update(frame))
            if i:  # the model's one-off start is not a frame's cost
                spent += time.perf_counter() - start
            sources.append(getattr(estimator, "source", "pose"))  # pose-don says which
        angles[name] = (np.array([e.angles[0] for e in estimates]),
                        np.array([e.trust > 0 for e in estimates]), np.array(sources))
        per_frame = spent / max(len(estimates) - 1, 1)
        result[name] = {"seconds_per_frame": per_frame, "ratio_to_decode": per_frame / decode,
                        "pose_frames": getattr(estimator, "pose_frames", len(estimates))}
        summary = run_mimic(stream_video(path, max_seconds=1.5 if quick else None,
                                         joint_ranges=human_joint_ranges(1)),
                            work / name, estimator=name, progress=False)
        result[name]["mimic_frames_per_s"] = summary["frames_per_s"]
        print(f"  1080p {name:9s} {result[name]['ratio_to_decode']:.1f}x decode, mimic "
              f"{summary['frames_per_s']:.1f} frames/s", flush=True)
    (a, seen, _), (b, gives, source) = angles["pose"], angles["pose-don"]
    both = seen & gives
    difference = np.degrees(np.abs(wrap_angle(b[both] - a[both])))
    result["pose_don_vs_pose"] = {
        "rmse_deg": float(np.sqrt(np.mean(difference ** 2))) if both.any() else None,
        "max_deg": float(difference.max()) if both.any() else None,
        "frames": int(both.sum()),
        # The same, split by what gave pose-seeded DON's estimate on each frame.
        "by_source": {name: {"frames": int(part.sum()),
                             "rmse_deg": float(np.sqrt(np.mean(difference[part] ** 2)))}
                      for name in ("pose", "don", "rolled")
                      if (part := source[both] == name).any()}}
    return result


# 5. A CNN for one camera, from the pose model's labels -------------------------------
TRAIN_CNN = Path(__file__).resolve().parents[2] / "training" / "train_cnn.py"


def camera_cnn(quick: bool) -> dict[str, Any]:
    """Per real video: `imimic label`, the CNN trained (`train_cnn.py`, the paper's budget)
    on the first 70% of the labelled frames and tested on the last 30%, against the pose
    labels, beside the shipped CNN on the same frames."""
    import json
    import sys

    from imimic_gym.clips.annotations import read_annotations, write_annotations
    from imimic_gym.estimators.cnn.estimator import default_checkpoint
    from imimic_gym.labels import label_video

    rows = []
    for path in sorted((REALDATA / "videos").glob("*.mp4")):
        work = work_folder(f"imimic_label_{path.stem}_")
        summary = label_video(path, work, progress=False)
        arms = read_annotations(work / "labels.json")  # frame order: ids follow frames
        cut = round(0.7 * len(arms))
        if cut < 1 or cut >= len(arms):
            rows.append({"video": path.name, "labelled": len(arms), "skipped": "too few"})
            continue
        write_annotations(work / "train.json", arms[:cut])
        write_annotations(work / "test.json", arms[cut:])
        budget = ["--cnn-epochs", "1", "--epochs", "2"] if quick else []
        subprocess.run([sys.executable, str(TRAIN_CNN), "--annotations", str(work / "train.json"),
                        "--test-annotations", str(work / "test.json"), "--images",
                        str(work / "images"), "--out", str(work / "cnn.pt"), "--json",
                        str(work / "trained.json"), *budget], check=True, cwd=work,
                       capture_output=True)
        subprocess.run([sys.executable, str(TRAIN_CNN), "--eval-only",
                        str(default_checkpoint(1)), "--annotations", str(work / "test.json"),
                        "--images", str(work / "images"), "--json", str(work / "shipped.json")],
                       check=True, cwd=work, capture_output=True)
        trained = json.loads((work / "trained.json").read_text())
        shipped = json.loads((work / "shipped.json").read_text())
        test = trained["test"]["cnn_refiner"]
        rows.append({
            "video": path.name, "frames": summary["frames"], "labelled": len(arms),
            "train_frames": cut, "test_frames": len(arms) - cut,
            "train_seconds": trained.get("train_seconds"),
            "trained": {"pcp_upper": test["pcp_all"]["upper"],
                        "pcp_lower": test["pcp_all"]["lower"],
                        "angle_error_deg": test["angle_error_deg"],
                        "pixel_error": test["mean_pixel_error"]},
            "shipped": {"pcp_upper": shipped["cnn_refiner"]["pcp_all"]["upper"],
                        "pcp_lower": shipped["cnn_refiner"]["pcp_all"]["lower"],
                        "angle_error_deg": shipped["cnn_refiner"]["angle_error_deg"],
                        "pixel_error": shipped["cnn_refiner"]["mean_pixel_error"]},
        })
        print(f"  camera CNN {path.name:20s} trained PCP {test['pcp_all']['upper']:.2f}/"
              f"{test['pcp_all']['lower']:.2f}, angle {test['angle_error_deg']:.1f} deg",
              flush=True)
    return {"rows": rows}


# 6. The CNN beyond our renderer -------------------------------------------------------
# Seeds of the randomised clips (train, test): far from the env's clips and both datasets.
DOMAIN_SEEDS = (120_000, 160_000)
# The two-link demonstrator (shoulder and elbow both move): people in photos hold their
# upper arm anywhere, the one-link demonstrator only out sideways.
DOMAIN_LINKS = 2
DOMAIN_CLIPS = (250, 25)  # x 4 frames: 1000 training and 100 test images
DOMAIN_EPOCHS = (10, 100)  # the paper's: the CNN alone, then CNN + refiner


def _real_frames(images: Path, quick: bool) -> tuple[list, dict[str, int]]:
    """Every real video labelled by the pose model (`labels.label_video`) into
    ``images/real/<video>/``: its labelled frames as arms with file names relative to
    ``images``, and how many each video gave."""
    from dataclasses import replace

    from imimic_gym.clips.annotations import read_annotations
    from imimic_gym.labels import label_video

    arms, counts = [], {}
    for path in sorted((REALDATA / "videos").glob("*.mp4"))[: 1 if quick else None]:
        out = images / "real" / path.stem
        label_video(path, out, progress=False)
        labelled = read_annotations(out / "labels.json")
        counts[path.name] = len(labelled)
        arms += [replace(a, file_name=f"real/{path.stem}/images/{a.file_name}")
                 for a in labelled]
    return arms, counts


def cnn_domain(quick: bool) -> dict[str, Any]:
    """The randomised synthetic set rendered, both CNNs trained (`train_cnn.py`, seed 1,
    ``DOMAIN_EPOCHS``) in a temporary folder, every CNN scored on the photos as in part
    1; the folder (real frames, weights trained on them) is deleted afterwards."""
    import shutil

    work = Path(tempfile.mkdtemp(prefix="imimic_cnn_domain_"))
    try:
        return _train_and_score(work, quick)
    finally:
        shutil.rmtree(work)


def _train_and_score(work: Path, quick: bool) -> dict[str, Any]:
    import json
    import shutil
    import sys
    from dataclasses import replace

    from imimic_gym.clips.annotations import write_annotations
    from imimic_gym.clips.dataset import generate_arms, rendered_image_path
    from imimic_gym.estimators.cnn.estimator import default_checkpoint

    images = work / "images"
    clips = (4, 2) if quick else DOMAIN_CLIPS
    start = time.perf_counter()
    synthetic = {split: generate_arms(DOMAIN_LINKS, n, seed, seed, f"random/{split}",
                                      progress=False, randomise=True)
                 for split, n, seed in zip(("train", "test"), clips, DOMAIN_SEEDS,
                                           strict=True)}
    render_seconds = time.perf_counter() - start
    for arm in synthetic["train"] + synthetic["test"]:  # one images folder for both sets
        (images / arm.file_name).parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(rendered_image_path(arm.render), images / arm.file_name)
    start = time.perf_counter()
    real, real_counts = _real_frames(images, quick)
    label_seconds = time.perf_counter() - start

    def numbered(arms: list) -> list:
        return [replace(a, image_id=i + 1) for i, a in enumerate(arms)]

    write_annotations(work / "test.json", numbered(synthetic["test"]))
    sets = {"randomised synthetic": synthetic["train"],
            "randomised synthetic + real frames": synthetic["train"] + real}
    epochs = ("1", "2") if quick else tuple(str(e) for e in DOMAIN_EPOCHS)
    annotations = photo_annotations(quick)
    runs: dict[str, dict[str, Any]] = {
        f"cnn (shipped, {links} link{'s' * (links > 1)})":
        {"checkpoint": str(default_checkpoint(links))} for links in (1, 2)}
    training = {}
    for k, (name, arms) in enumerate(sets.items()):
        write_annotations(work / f"train{k}.json", numbered(arms))
        started = time.perf_counter()
        subprocess.run([sys.executable, str(TRAIN_CNN), "--links", str(DOMAIN_LINKS),
                        "--annotations", str(work / f"train{k}.json"), "--test-annotations",
                        str(work / "test.json"), "--images", str(images), "--seed", "1",
                        "--threads", "2", "--cnn-epochs", epochs[0], "--epochs", epochs[1],
                        "--out", str(work / f"cnn{k}.pt"), "--json", str(work / f"report{k}.json")],
                       check=True, cwd=work, capture_output=True)
        trained = json.loads((work / f"report{k}.json").read_text())
        test = trained["test"]["cnn_refiner"]
        training[name] = {
            "train_images": trained["train_images"], "train_seconds": trained["train_seconds"],
            "wall_seconds": time.perf_counter() - started,
            "synthetic_test": {"images": trained["test"]["n_images"],
                               "pcp_upper": test["pcp_all"]["upper"],
                               "pcp_lower": test["pcp_all"]["lower"],
                               "angle_error_deg": test["angle_error_deg"]}}
        print(f"  cnn_domain trained {name}: {trained['train_images']} images in "
              f"{trained['train_seconds']:.0f} s", flush=True)
        runs[f"cnn ({name})"] = {"checkpoint": str(work / f"cnn{k}.pt")}
    rows, count = {}, 0
    for name, params in runs.items():
        rows[name], count = photo_row(annotations, name, "cnn", **params)
    return {"photos": count, "links": DOMAIN_LINKS, "epochs": [int(e) for e in epochs],
            "synthetic_clips": list(clips), "seeds": list(DOMAIN_SEEDS),
            "real_frames": real_counts, "render_seconds": render_seconds,
            "label_seconds": label_seconds, "training": training, "rows": rows}


# 4. Rendered clips --------------------------------------------------------------------
def rendered(quick: bool) -> dict[str, Any]:
    seeds = RENDERED_SEEDS[:3] if quick else RENDERED_SEEDS
    out = {}
    for scenario in RENDERED:
        clips = []
        for seed in seeds:
            spec = get_scenario(scenario, seed=seed)
            clip = load_clip(spec, progress=False)
            context = clip_context(spec, clip)
            truth = clip.truth.angles[:, 0]
            runs = {name: run_estimator(build_estimator(name, context), clip.frames)
                    for name in ("pose", "don", "cnn")}
            found = np.array([e.trust > 0 for e in runs["pose"]])
            found[: round(WARM_UP_S * clip.fps)] = False  # DON's warm-up, for all three
            row = {"seed": seed, "found_fraction": float(found.mean())}
            for name, estimates in runs.items():
                angles = np.array([e.angles[0] for e in estimates])
                row[f"{name}_rmse_deg"] = (float(np.degrees(np.sqrt(np.mean(
                    wrap_angle(angles[found] - truth[found]) ** 2)))) if found.any() else None)
            clips.append(row)
        out[scenario] = {
            "seeds": [seeds[0], seeds[-1]],
            "found_fraction": with_interval([c["found_fraction"] for c in clips]),
            **{f"{name}_rmse_deg": with_interval([c[f"{name}_rmse_deg"] for c in clips
                                             if c[f"{name}_rmse_deg"] is not None])
               for name in ("pose", "don", "cnn")},
            "worst_pose": sorted(clips, key=lambda c: -(c["pose_rmse_deg"] or 0))[:WORST],
        }
        print(f"  rendered {scenario:18s} found {out[scenario]['found_fraction']['value']:.2f}"
              f", RMSE pose {out[scenario]['pose_rmse_deg']['value']:.1f} don "
              f"{out[scenario]['don_rmse_deg']['value']:.1f} cnn "
              f"{out[scenario]['cnn_rmse_deg']['value']:.1f}", flush=True)
    return out


# 7. The env on real footage ------------------------------------------------------------
def oracle_labels(quick: bool) -> dict[str, Any]:
    """The oracle in ``ImitateVideo-v0(clip=video, annotations="pose")``, per shared video
    and number of links: its RMSE and largest error (deg) on the labelled frames."""
    import gymnasium as gym

    from imimic_gym.controllers import OracleController
    from imimic_gym.rollout import run_episode

    rows = []
    for path in sorted((REALDATA / "videos").glob("*.mp4")):
        for links in (1, 2):
            env = gym.make("ImitateVideo-v0", clip=str(path), annotations="pose",
                           n_links=links, n_frames=40 if quick else None)
            metrics = run_episode(env, OracleController(env), seed=0).metrics()
            env.close()
            rows.append({"video": path.name, "links": links, "frames": metrics["frames"],
                         "labelled_frames": metrics["truth_frames"],
                         "rmse_deg": metrics["rmse_deg"],
                         "max_error_deg": metrics["max_error_deg"]})
            print(f"  oracle on labels {path.name:20s} {links} link(s): RMSE "
                  f"{_num(metrics['rmse_deg'])} deg on {metrics['truth_frames']} of "
                  f"{metrics['frames']} frames", flush=True)
    return {"rows": rows}


PARTS = ("photos", "videos", "hd", "camera_cnn", "rendered", "cnn_domain", "oracle_labels")


def run(args: Any) -> dict[str, Any]:
    """Every part (or ``args.parts``), with the machine they ran on."""
    parts = args.parts or PARTS
    unknown = sorted(set(parts) - set(PARTS))
    if unknown:
        raise SystemExit(f"suite real has no part {', '.join(unknown)}; parts: {PARTS}")
    data: dict[str, Any] = {"machine": machine(), "quick": bool(args.quick)}
    real = {"photos": photos, "videos": videos, "hd": hd, "camera_cnn": camera_cnn,
            "cnn_domain": cnn_domain, "oracle_labels": oracle_labels}
    if REALDATA.is_dir():
        print(f"reading real material from {REALDATA} (evaluation only)")
    for part in parts:
        if part in real and not REALDATA.is_dir():
            print(f"no real material at {REALDATA}: {part} not measured")
            continue
        data[part] = (real[part] if part in real else rendered)(args.quick)
    return data


# The report ---------------------------------------------------------------------------
def _ci(cell: dict[str, Any] | None, digits: int = 2, scale: float = 1.0) -> str:
    """"value (low-high)" of an `interval` cell."""
    if not cell or cell.get("value") is None:
        return "-"
    return (f"{scale * cell['value']:.{digits}f} ({scale * cell['low']:.{digits}f}-"
            f"{scale * cell['high']:.{digits}f})")


def _num(value: Any, digits: int = 2) -> str:
    return "-" if value is None else f"{value:.{digits}f}"


def _table(head: list[str], rows: list[list[str]]) -> str:
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    return "\n".join(lines + ["| " + " | ".join(row) + " |" for row in rows])


QUICK = "**A quick run (`--quick`): a few photos, frames and clips; not the reported figures.**"


def _worst_photo(worst: dict[str, Any]) -> str:
    error = worst["elbow_error_deg"]
    return f"`{worst['photo']}` ({'none found' if error is None else f'{error:.0f}'})"


def render(data: dict[str, Any]) -> str:
    m = data["machine"]
    out = [f"""## Real people: the pose model, pose-seeded DON and every estimator (suite `real`)

Command: `.venv/bin/python benchmarks/run.py real` (JSON: `benchmarks/results/real.json`;
this section is rendered from it). Machine: {m['cpu']}, {m['cores']} cores. 95% intervals
are percentile bootstraps (2000 resamples, seed 0) over photos or clips.
{QUICK if data.get("quick") else ""}"""]
    photos_ = data.get("photos")
    if photos_:
        out.append(f"""### Photos: {photos_['photos']} COCO photos (`../shared/realdata/coco_mini`)

The largest labelled person's labelled arm (their left where all three keypoints are
labelled, else their right), PCP@0.5 (both ends within half the limb's true length), and
the elbow angle (forearm from upper arm) error where the estimator gave keypoints: what
`imimic eval --photos person_keypoints.json --images images --estimator pose cnn` prints.
The pose model reads each photo from a fresh start and gives that same side of the person
it finds, every position it has (no confidence floor); a photo where it finds nobody
counts as wrong. DON, MOG2 and CamShift read motion and cannot score a single photo.

""" + _photo_table(photos_["rows"]))
    videos_ = data.get("videos")
    if videos_:
        out.append("""### Videos (`../shared/realdata/videos`, no truth)

The reference is the pose model on every frame, where it is confident (its shoulder,
elbow and wrist at 0.5 or more). Each estimator runs as `imimic mimic` sets it up with no
flags (one link; the reference link down the image; a human arm's range for the pose
estimators, the servo's -60..60 for the others). "Covers": the share of the reference's
confident frames on which the estimator gave an estimate (trust > 0); "no output": the
share of all frames without one. Correlation and RMSE after the mean offset are on the
frames where both gave one. Speed: the estimator's seconds per frame on decoded frames,
over OpenCV's decoding of the same file in the same run (median of 3).

""" + _table(["video", "estimator", "covers", "no output", "correlation",
              "RMSE after offset (deg)", "time / decode"],
             [[f"`{r['video']}` ({r['resolution']}, {r['frames']} frames)", r["estimator"],
               _num(r["estimate_where_reference_confident"]), _num(r["no_output_fraction"]),
               _num(r["correlation"]), _num(r["rmse_after_offset_deg"], 1),
               f"{r['ratio_to_decode']:.1f}"]
              for r in videos_["rows"]]))
    hd_ = data.get("hd")
    if hd_:
        versus = hd_["pose_don_vs_pose"]
        out.append(f"""### 1920x1080

{hd_['clip']}: OpenCV decodes a frame in {1000 * hd_['decode_seconds_per_frame']:.1f} ms.

""" + _table(["estimator", "ms per frame", "x decode", "frames the pose model read",
              "`imimic mimic` frames/s"],
             [[name, f"{1000 * hd_[name]['seconds_per_frame']:.1f}",
               f"{hd_[name]['ratio_to_decode']:.1f}", str(hd_[name]["pose_frames"]),
               f"{hd_[name]['mimic_frames_per_s']:.1f}"] for name in ("pose", "pose-don")])
            + f"""

Pose-seeded DON against the pose model on every frame of that clip: RMSE
{_num(versus['rmse_deg'], 1)} deg, largest {_num(versus['max_deg'], 1)} deg, over
{versus['frames']} frames where both read the arm.""" + "".join(
            f"{' By what gave the estimate:' if i == 0 else ';'} {SOURCES[name]} "
            f"{part['rmse_deg']:.1f} deg ({part['frames']} frames)"
            for i, (name, part) in enumerate(versus.get("by_source", {}).items()))
            + ("." if versus.get("by_source") else ""))
    camera = data.get("camera_cnn")
    if camera:
        out.append("""### A CNN for one camera, trained on the pose model's labels

`imimic label --video V` labels each real video; the paper's CNN + refiner is trained
(`training/train_cnn.py`, its default budget: 10 + 100 epochs) on the first 70% of the
labelled frames and tested on the last 30%, against the pose model's labels (not hand
labels), beside the shipped CNN (trained on our renders) on the same test frames. Mean
absolute elbow-angle error, degrees.

""" + _table(["video", "labelled frames (train / test)", "trained: PCP upper / lower",
              "trained: elbow error", "shipped: PCP upper / lower", "shipped: elbow error"],
             [[f"`{r['video']}`", f"{r['labelled']} ({r['train_frames']} / {r['test_frames']})",
               f"{r['trained']['pcp_upper']:.2f} / {r['trained']['pcp_lower']:.2f}",
               f"{r['trained']['angle_error_deg']:.1f}",
               f"{r['shipped']['pcp_upper']:.2f} / {r['shipped']['pcp_lower']:.2f}",
               f"{r['shipped']['angle_error_deg']:.1f}"]
              if "trained" in r else [f"`{r['video']}`", str(r["labelled"]), "-", "-", "-", "-"]
              for r in camera["rows"]]))
    domain = data.get("cnn_domain")
    if domain:
        out.append(_render_cnn_domain(domain))
    rendered_ = data.get("rendered", {})
    if rendered_:
        out.append("""### Our rendered person, against exact truth

Seeds 6000-6029 of each scenario (30 clips, a pool no choice has touched). "Found": the
share of frames where the pose model reads the moving arm confidently. The RMSE (deg,
mean over clips) of each estimator's forearm angle is on those frames only, after DON's
0.5 s warm-up, so the three are compared on the same frames.

""" + _table(["scenario", "found", "pose RMSE", "DON RMSE", "CNN RMSE",
              "pose's worst clips (seed: RMSE)"],
             [[f"`{name}`", _ci(r["found_fraction"]), _ci(r["pose_rmse_deg"], 1),
               _ci(r["don_rmse_deg"], 1), _ci(r["cnn_rmse_deg"], 1),
               ", ".join(f"{c['seed']}: {_num(c['pose_rmse_deg'], 0)}"
                         for c in r["worst_pose"][:3])]
              for name, r in rendered_.items()]))
    oracle = data.get("oracle_labels")
    if oracle:
        out.append("""### The env on real footage: the oracle against the pose model's labels

`ImitateVideo-v0(clip=VIDEO, annotations="pose", n_links=L)`: the robot has a human arm's
joint ranges; the truth is the pose model's arm, one arm for the video, frames without a
reading (or with a link seen end-on) unlabelled and unscored
(`docs/decisions/pose-truth.md`). The oracle controller (true angles one frame ahead,
position control); RMSE and largest error over the labelled frames.

""" + _table(["video", "links", "labelled frames", "RMSE (deg)", "largest (deg)"],
             [[f"`{r['video']}`", str(r["links"]), f"{r['labelled_frames']} of {r['frames']}",
               _num(r["rmse_deg"]), _num(r["max_error_deg"], 1)] for r in oracle["rows"]]))
    verdicts = acceptance(data)
    if verdicts:
        out.append("### Against the real-footage issue's targets\n\n"
                   + "\n".join(f"- {line}" for line in verdicts))
    return "\n\n".join(out) + "\n"


def _photo_table(rows: dict[str, Any]) -> str:
    """The photo table of part 1 for ``rows`` (estimator name: `photo_row`)."""
    return _table(["estimator", "PCP upper arm", "PCP lower arm", "photos with keypoints",
                   "elbow error, median (deg)", "worst photos (elbow error, deg)"],
                  [[name, _ci(r["pcp_upper"]), _ci(r["pcp_lower"]), str(r["found"]),
                    _ci(r["elbow_error_deg_median"], 1),
                    ", ".join(_worst_photo(w) for w in r["worst"][:3])]
                   for name, r in rows.items()])


def _render_cnn_domain(domain: dict[str, Any]) -> str:
    train_clips, test_clips = domain["synthetic_clips"]
    cnn_epochs, epochs = domain["epochs"]
    real = ", ".join(f"`{video}` {n}" for video, n in domain["real_frames"].items())
    training = _table(
        ["trained on", "training images", "training (s)", "synthetic test: PCP upper / lower",
         "synthetic test: elbow error (deg)"],
        [[name, str(t["train_images"]), f"{t['train_seconds']:.0f}",
          f"{t['synthetic_test']['pcp_upper']:.2f} / {t['synthetic_test']['pcp_lower']:.2f}",
          f"{t['synthetic_test']['angle_error_deg']:.1f}"]
         for name, t in domain["training"].items()])
    return f"""### The CNN beyond our renderer: domain randomisation and real frames

Command: `.venv/bin/python benchmarks/run.py real --parts cnn_domain`. A randomised
synthetic set (`training/make_dataset.py --randomise`: clothing, sleeve and skin colours,
backdrop colour, tiles and clutter, the light's strength, direction and colour, the
camera's distance, height, tilt, sideways place and field of view, body sway) of the
{domain['links']}-link demonstrator (shoulder and elbow move): {train_clips} training
clips and {test_clips} test clips, 4 frames each (seeds from {domain['seeds'][0]} and
{domain['seeds'][1]}), rendered in {domain['render_seconds']:.0f} s. The real frames are
every frame the pose model labelled in the shared videos (`imimic label`; {real}; labelled
in {domain['label_seconds']:.0f} s), its labels taken as truth. Each CNN is the paper's CNN +
refiner trained by `training/train_cnn.py --links {domain['links']} --seed 1` for
{cnn_epochs} + {epochs} epochs (the paper's budget),
in a temporary folder that is deleted afterwards: no weights trained on real frames are
kept. Both are tested on the same randomised synthetic test images:

""" + training + f"""

On the {domain['photos']} COCO photos, scored as in the photo table above (the shipped CNNs
again, for the same run):

""" + _photo_table(domain["rows"])


def _verdict(ok: bool) -> str:
    return "**met**" if ok else "**missed**"


def acceptance(data: dict[str, Any]) -> list[str]:
    """The issue's measurable targets, each met or missed by the figures in ``data``."""
    lines = []
    oracle = data.get("oracle_labels")
    if oracle:
        one = [r for r in oracle["rows"] if r["links"] == 1]
        worst = max((r["rmse_deg"] for r in one if r["rmse_deg"] is not None), default=None)
        lines.append(f"The oracle within 5 degrees RMSE of the pose labels on every shared "
                     f"video's labelled frames (one link): "
                     f"{_verdict(worst is not None and worst <= 5.0)} (worst {_num(worst)}).")
    photos_ = data.get("photos", {}).get("rows", {}).get("pose")
    if photos_:
        upper, lower = photos_["pcp_upper"]["value"], photos_["pcp_lower"]["value"]
        lines.append(f"Pose PCP@0.5 on the COCO photos at least 0.45 upper and 0.28 lower: "
                     f"{_verdict(upper >= 0.45 and lower >= 0.28)} ({upper:.2f} and "
                     f"{lower:.2f}; the intervals above are wide: 48 photos).")
    domain = data.get("cnn_domain")
    if domain and photos_:
        pose_upper, pose_lower = photos_["pcp_upper"]["value"], photos_["pcp_lower"]["value"]
        for name in domain["training"]:
            row = domain["rows"][f"cnn ({name})"]
            upper, lower = row["pcp_upper"]["value"], row["pcp_lower"]["value"]
            lines.append(f"The CNN trained on {name} reaches the pose model's PCP@0.5 on the "
                         f"photos ({pose_upper:.2f} upper, {pose_lower:.2f} lower): "
                         f"{_verdict(upper >= pose_upper and lower >= pose_lower)} "
                         f"({upper:.2f} and {lower:.2f}; "
                         "`docs/decisions/cnn-domain-randomisation.md` says why).")
    hd_ = data.get("hd")
    if hd_:
        pose_don, versus = hd_["pose-don"], hd_["pose_don_vs_pose"]
        lines.append(f"Pose-seeded DON at most 2x OpenCV's decode at 1920x1080: "
                     f"{_verdict(pose_don['ratio_to_decode'] <= 2.0)} "
                     f"({pose_don['ratio_to_decode']:.1f}x: the pose model still read "
                     f"{pose_don['pose_frames']} frames, against {hd_['pose']['pose_frames']} "
                     f"when it runs alone, at {hd_['pose']['ratio_to_decode']:.1f}x).")
        within = versus["rmse_deg"] is not None and versus["rmse_deg"] <= 3.0
        lines.append(f"Pose-seeded DON within 3 degrees RMSE of the pose model over every "
                     f"frame: "
                     f"{_verdict(within)} (RMSE {_num(versus['rmse_deg'], 1)}, largest "
                     f"{_num(versus['max_deg'], 1)} degrees).")
        default = hd_["pose"]["mimic_frames_per_s"]
        lines.append(f"`imimic mimic` keeps up with 30 fps at 1920x1080 with its default "
                     f"estimator: {_verdict(default >= 30)} "
                     f"({hd_['pose']['mimic_frames_per_s']:.1f} frames/s with `pose`, the "
                     f"default; {hd_['pose-don']['mimic_frames_per_s']:.1f} with `pose-don`).")
    videos_ = data.get("videos")
    if videos_:
        rows = [r for r in videos_["rows"] if r["estimator"] == "pose-don"]
        worst = min(r["correlation"] for r in rows if r["correlation"] is not None)
        covered = all(r["estimate_where_reference_confident"] >= 0.9 for r in rows)
        lines.append("On every shared clip an estimate on at least 90% of the frames where the "
                     "pose model sees the arm, correlated at least 0.9 with it: met by the "
                     "default (`pose`) trivially, as it is the pose model; `pose-don` "
                     f"{_verdict(worst >= 0.9 and covered)}"
                     f" (lowest correlation {worst:.2f}).")
    return lines
