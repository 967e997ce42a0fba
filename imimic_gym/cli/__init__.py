"""The `imimic` command: demo, clip, scenarios, eval, cache, bench, mimic, label."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any, cast

import imimic_gym  # noqa: F401  (registers the env, sets headless GL)
from imimic_gym.cli.cache import add_cache
from imimic_gym.cli.common import (
    CommandError,
    at_least,
    estimator_names,
    positive,
    print_table,
    save_json,
)
from imimic_gym.cli.evaluate import add_eval

# What `imimic mimic` runs unless told: it finds a person and their moving arm by itself.
MIMIC_ESTIMATOR = "pose"


def _demo_estimator(requested: str | None, scenario: str) -> str:
    """``--estimator`` as given, or by default DON where it follows the arm well (one or
    two moving links) and the oracle elsewhere."""
    from imimic_gym.clips.scenarios import get_scenario

    n_links = get_scenario(scenario).n_links
    if requested is None:
        if n_links <= 2:
            return "don"
        print(f"  DON follows {scenario}'s {n_links} links only roughly (benchmarks/"
              "RESULTS.md), so the demo runs the oracle (the true angles); "
              "--estimator don runs it anyway.")
        return "oracle"
    return requested


def cmd_demo(args: argparse.Namespace) -> int:
    import gymnasium as gym

    from imimic_gym.clips.video import write_video
    from imimic_gym.controllers import EstimateTarget, OracleController, PDController
    from imimic_gym.plots import plot_tracking
    from imimic_gym.rollout import run_episode

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    print(f"imimic demo: scenario {args.scenario}, seed {args.seed}, control {args.control}")
    args.estimator = _demo_estimator(args.estimator, args.scenario)
    kwargs = {"n_frames": args.frames} if args.frames else {}
    env = gym.make("ImitateVideo-v0", scenario=args.scenario, control=args.control,
                   clip_seeds=(args.seed,), render_mode="rgb_array", **kwargs)
    if args.estimator == "oracle":
        print("  estimator: oracle. The robot reads the true angles: this shows the control "
              "loop's upper bound, not vision.")
        controller = OracleController(env)
    else:
        from imimic_gym.estimators.registry import UnsupportedClipError, get_estimator
        from imimic_gym.wrappers import RegistryObservation

        print(f"  estimator: {get_estimator(args.estimator).summary}; controller: PD on its "
              "angles")
        try:
            env = RegistryObservation(env, args.estimator, keep_frame=False)
        except UnsupportedClipError as error:
            raise CommandError(f"imimic demo: {error}") from error
        controller = PDController(env, EstimateTarget(env))
    trajectory = run_episode(env, controller, seed=args.seed, record=True)
    fps = float(env.metadata["render_fps"])
    env.close()
    write_video(out / "demo.mp4", trajectory.frames, fps)
    title = (f"{args.scenario}: human (solid) vs robot (dashed), "
             f"{args.estimator} + {args.control}")
    plot_tracking(trajectory, out / "angles.png", title=title)
    metrics = {
        **trajectory.metrics(),
        "scenario": args.scenario,
        "seed": args.seed,
        "controller": "oracle" if args.estimator == "oracle" else "pd",
        "control": args.control,
        "estimator": args.estimator,
    }
    (out / "metrics.json").write_text(json.dumps(metrics, indent=2) + "\n")
    print(f"wrote {out / 'demo.mp4'}, {out / 'angles.png'}, {out / 'metrics.json'}")
    print_table(metrics)
    return 0


def cmd_clip(args: argparse.Namespace) -> int:
    from imimic_gym.clips.cache import load_clip
    from imimic_gym.clips.scenarios import get_scenario
    from imimic_gym.clips.video import write_video

    overrides = {"seed": args.seed}
    if args.frames:
        overrides["n_frames"] = args.frames
    spec = get_scenario(args.scenario, **overrides)
    clip = load_clip(spec)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    stem = out / f"{args.scenario}-seed{args.seed}"
    write_video(stem.with_suffix(".mp4"), clip.frames, clip.fps)
    truth = clip.truth
    assert truth is not None
    stem.with_suffix(".json").write_text(json.dumps({
        "meta": clip.meta,
        "fps": clip.fps,
        "units": {"angles": "rad", "angular_velocity": "rad/s",
                  "angular_acceleration": "rad/s^2", "keypoints": "pixels (x, y)"},
        "keypoint_names": list(truth.keypoint_names),
        "angles": truth.angles.tolist(),
        "angular_velocity": truth.angular_velocity.tolist(),
        "angular_acceleration": truth.angular_acceleration.tolist(),
        "keypoints": truth.keypoints.round(2).tolist(),
        "visible": truth.visible.tolist(),
        "occlusion": truth.occlusion.round(4).tolist(),
    }) + "\n")
    print(f"wrote {stem.with_suffix('.mp4')} and {stem.with_suffix('.json')} "
          f"({len(clip)} frames, {clip.width}x{clip.height}, {clip.fps:g} fps)")
    return 0


def cmd_scenarios(args: argparse.Namespace) -> int:
    from dataclasses import asdict

    from imimic_gym.clips.scenarios import SCENARIOS

    for name, spec in sorted(SCENARIOS.items()):
        fields = {k: v for k, v in asdict(spec).items() if k not in ("name", "seed")}
        print(f"{name:20s} " + ", ".join(f"{k}={v}" for k, v in fields.items()))
    return 0


def cmd_bench(args: argparse.Namespace) -> int:
    from imimic_gym.bench import bench_env, bench_render, machine

    result: dict[str, Any] = {"machine": machine()}
    if args.what == "don":
        return _bench_don(args, result)
    print("ImitateVideo-v0 vs Reacher-v5, steps/s (median of alternating runs)...")
    result.update(bench_env(steps=args.steps, repeats=args.repeats))
    print(f"  imitate {result['imitate_steps_per_s']:.0f}  reacher "
          f"{result['reacher_steps_per_s']:.0f}  ratio {result['ratio']:.2f} (target >= 0.5)")
    print("clip rendering at 240x320, frames/s, truth included, no cache...")
    result["render_frames_per_s"] = bench_render()
    for name, fps in result["render_frames_per_s"].items():
        print(f"  {name:20s} {fps:6.0f}")
    save_json(args.json, result)
    return 0


def _bench_don(args: argparse.Namespace, result: dict[str, Any]) -> int:
    from imimic_gym.bench import bench_don, don_window_and_lighting

    print("DON, baselines and raw OpenCV MOG2, CPU ms per frame on the same frames, "
          "1 thread...")
    result.update(bench_don())
    print(f"  {'resolution':11s} {'DON':>7s} {'paper':>7s} {'MOG2 est':>9s} {'CamShift':>9s} "
          f"{'MOG2 raw':>9s} {'DON/MOG2':>9s} {'paper/MOG2':>10s}")
    for row in result["rows"]:
        print(f"  {row['resolution']:11s} {row['don_ms']:7.2f} {row['don_paper_ms']:7.2f} "
              f"{row['mog2_estimator_ms']:9.2f} {row['camshift_estimator_ms']:9.2f} "
              f"{row['mog2_raw_ms']:9.2f} {row['ratio_mog2']:9.2f} "
              f"{row['ratio_mog2_paper']:10.2f}")
    print("  (paper: DON with the paper's layers only, without the appearance layer)")
    prefix = str(Path(args.json).with_suffix("")) if args.json else "bench_don"
    print("time against N and detected area against light (paper Fig. 3)...")
    result["figure3"] = don_window_and_lighting(prefix)
    print(f"  wrote {prefix}_window.png and {prefix}_lighting.png")
    save_json(args.json, result)
    return 0


def cmd_mimic(args: argparse.Namespace) -> int:
    """`imimic mimic`; footage that cannot be used is reported in one line (exit code 2)."""
    from imimic_gym.clips.video import VideoFormatError, VideoOpenError
    from imimic_gym.estimators.registry import get_estimator

    entry = get_estimator(args.estimator)
    if args.pivot and "pivot" not in entry.params:
        raise CommandError(f"imimic mimic: --pivot is DON's; {args.estimator} finds the joints "
                         "itself")
    for option, pair in (("--servo-range", args.servo_range),
                         ("--joint-range", args.joint_range)):
        if pair is not None and not pair[0] < pair[1]:
            raise CommandError(f"imimic mimic: {option} takes LOW HIGH in degrees with LOW < "
                             f"HIGH, got {pair[0]:g} {pair[1]:g}")
    if args.preview_height < 0:
        raise CommandError(f"imimic mimic: --preview-height takes 0 (the footage's size) or a "
                         f"positive number of rows, got {args.preview_height}")
    if args.arm != "auto" and "arm" not in entry.params:
        raise CommandError(f"imimic mimic: --arm is for the estimators that find a person "
                         f"(pose, pose-don); {args.estimator} follows whatever moves")
    if args.links not in entry.links:
        raise CommandError(f"imimic mimic: {args.estimator} follows {entry.links_text}; "
                         f"--links {args.links}")
    try:
        return _mimic(args)
    except (VideoOpenError, VideoFormatError) as err:
        print(f"imimic mimic: {err}", file=sys.stderr)
        return 2


def _mimic(args: argparse.Namespace) -> int:
    import math

    from imimic_gym.clips.video import FrameStream, stream_video
    from imimic_gym.mimic import run_mimic

    source = args.video if args.video is not None else args.camera
    live = args.video is None
    servo = None
    if args.serial:
        from imimic_gym.servo import ServoBridge

        servo = ServoBridge(args.serial, baud=args.baud, servo_range_deg=tuple(args.servo_range),
                            zero_deg=args.servo_zero)
        print(f"  servo bridge on {args.serial} at {args.baud} baud "
              f"({'open' if servo.connected else 'not open yet: retrying'})")
    from imimic_gym.estimators.registry import get_estimator

    if args.joint_range is not None:
        low, high = (math.radians(v) for v in args.joint_range)
        ranges: list[tuple[float, float]] = [(low, high)] * args.links
    elif get_estimator(args.estimator).real_people:
        from imimic_gym.estimators.pose import human_joint_ranges

        ranges = list(human_joint_ranges(args.links))
    else:
        ranges = [(math.radians(-60.0), math.radians(60.0))] * args.links
    try:
        clip = stream_video(
            source, n_links=args.links,
            reference_direction=math.radians(args.reference_direction),
            joint_ranges=ranges, fps=args.fps, max_seconds=args.max_seconds,
        )
    except BaseException:
        if servo is not None:
            servo.close()
        raise
    frames = cast(FrameStream, clip.frames)  # stream_video's clip streams its frames
    print(f"imimic mimic: {clip.meta['path']} ({clip.width}x{clip.height}, {clip.fps:g} fps"
          f"{', live' if live else ''}"
          f"{f', {len(clip)} frames' if frames.length_known else ''}), "
          f"estimator {args.estimator}, "
          f"control {args.control}" + (" (Ctrl-C stops and keeps the outputs)" if live else ""))
    if args.pivot and not (0 <= args.pivot[0] < clip.width and 0 <= args.pivot[1] < clip.height):
        frames.close()
        if servo is not None:
            servo.close()
        raise CommandError(f"imimic mimic: --pivot {args.pivot[0]:g} {args.pivot[1]:g} lies "
                           f"outside the {clip.width}x{clip.height} frame of {clip.meta['path']}")
    params: dict[str, object] = {"pivot": tuple(args.pivot)} if args.pivot else {}
    if args.arm != "auto":
        params["arm"] = args.arm
    summary = run_mimic(clip, args.out, estimator=args.estimator, control=args.control,
                        estimator_params=params, servo=servo,
                        realtime=not live and (args.realtime or servo is not None),
                        preview_height=args.preview_height or None)
    out = Path(args.out)
    print(f"{summary['ended']}: wrote {out / 'mimic.mp4'}, {out / 'angles.png'}, "
          f"{out / 'mimic.csv'}, {out / 'mimic.json'}")
    print_table({k: v for k, v in summary.items() if k not in ("source",)})
    return 0


def cmd_label(args: argparse.Namespace) -> int:
    """`imimic label`: the pose model's labels of a video, as COCO keypoints."""
    from imimic_gym.clips.video import VideoFormatError, VideoOpenError
    from imimic_gym.labels import label_video

    if not 0.0 <= args.min_confidence <= 1.0:
        raise CommandError(f"imimic label: --min-confidence is in [0, 1], got "
                         f"{args.min_confidence}")
    try:
        summary = label_video(args.video, args.out, arm=args.arm,
                              min_confidence=args.min_confidence)
    except (VideoOpenError, VideoFormatError, OSError) as err:
        print(f"imimic label: {err}", file=sys.stderr)
        return 2
    print(f"labelled {summary['labelled']} of {summary['frames']} frames: wrote "
          f"{summary['labels']} and {summary['images']}/ (train: python training/train_cnn.py "
          f"--annotations {summary['labels']} --images {summary['images']})")
    return 0


def _add_label(sub: argparse._SubParsersAction) -> None:
    label = sub.add_parser(
        "label", help="label a video's arm with the pose model (COCO keypoints, for CVAT, "
                      "Label Studio and train_cnn.py)",
        description="Run the pretrained pose model over a video and write --out/images/ "
                    "(every frame as JPEG) and --out/labels.json (COCO keypoints, one 'arm' "
                    "category: shoulder, elbow, wrist; an annotation on each frame where "
                    "all three reach --min-confidence, the others left unlabelled). CVAT and "
                    "Label Studio import it for a person to correct; training/train_cnn.py "
                    "--annotations --images trains the CNN on it; ImitateVideo-v0("
                    "clip=VIDEO, annotations=labels.json) scores on it.",
    )
    label.add_argument("--video", required=True, metavar="FILE",
                       help="a recorded video (anything OpenCV reads) or an image pattern")
    label.add_argument("--out", default="labels_out", help="output folder (default: "
                                                           "%(default)s)")
    label.add_argument("--arm", default="auto", choices=("auto", "left", "right"),
                       help="the person's arm to label (default: auto, the one that moves)")
    label.add_argument("--min-confidence", type=float, default=0.5,
                       help="label a frame when shoulder, elbow and wrist all reach this "
                            "confidence (default: %(default)s)")
    label.set_defaults(func=cmd_label)


def _add_mimic(sub: argparse._SubParsersAction) -> None:
    mimic = sub.add_parser(
        "mimic", help="estimator + controller on a video file or live camera; drives the robot",
        description="Run an estimator and a PD controller on real footage, frame by frame, "
                    "driving the simulated arm (and, with --serial, a real servo arm). Writes "
                    "into --out: mimic.mp4 (the footage with the estimated link drawn on it, "
                    "beside the robot), angles.png (estimate vs robot), mimic.csv (per frame: "
                    "time, estimated angle, omega, torque, eta, robot angle, latency) and "
                    "mimic.json (frames/s, latency). By default a pretrained pose model finds "
                    "the person and the arm that moves, and the robot copies their elbow "
                    "(--links 2: shoulder and elbow); with nobody in view the robot holds. "
                    "Footage of unknown geometry gets defaults: the reference link points "
                    "down the image, and the joint range is a human arm's (the servo's "
                    "120 degrees for DON and the baselines); override them below. Memory "
                    "stays bounded however long a camera runs.",
    )
    where = mimic.add_mutually_exclusive_group(required=True)
    where.add_argument("--video", default=None, metavar="FILE",
                       help="a recorded video (anything OpenCV reads) or an image pattern "
                            "such as frames_%%04d.png")
    where.add_argument("--camera", default=None, metavar="INDEX|URL",
                       help="a live camera index (0) or stream URL; shows frames/s and "
                            "latency, stops on Ctrl-C or when the camera disappears")
    mimic.add_argument("--estimator", default=MIMIC_ESTIMATOR,
                       choices=estimator_names(video_only=True),
                       help="the vision estimator (default: %(default)s, which finds a "
                            "person by itself; don is the paper's, for a lone moving link "
                            "such as the servo)")
    mimic.add_argument("--links", type=int, default=1,
                       help="moving links to copy, a chain (default: %(default)s; DON "
                            "handles 1 to 3, the CNN 1 or 2)")
    mimic.add_argument("--control", default="position",
                       choices=("position", "velocity", "torque"),
                       help="robot actuation (default: %(default)s, the paper's servo)")
    mimic.add_argument("--reference-direction", type=float, default=-90.0, metavar="DEG",
                       help="image direction of the fixed reference link, degrees CCW from "
                            "image right (default: %(default)s = image down)")
    mimic.add_argument("--joint-range", type=float, nargs=2, default=None,
                       metavar=("LOW", "HIGH"),
                       help="the robot's joint range in degrees from the reference (default: "
                            "a human arm's for the estimators that find a person, -175 175 "
                            "at the elbow; the paper's 120-degree servo, -60 60, for the "
                            "others)")
    mimic.add_argument("--arm", default="auto", choices=("auto", "left", "right"),
                       help="which of the person's arms to copy (their own left or right; "
                            "default: auto, the arm that moves)")
    mimic.add_argument("--pivot", type=float, nargs=2, default=None, metavar=("X", "Y"),
                       help="the joint's pixel position if known (default: found by DON)")
    mimic.add_argument("--fps", type=positive, default=None,
                       help="frame rate for sources that report none (image patterns; "
                            "cameras default to 30)")
    mimic.add_argument("--max-seconds", type=positive, default=None,
                       help="stop after this much footage, seconds (default: the whole "
                            "file; a camera runs until Ctrl-C)")
    mimic.add_argument("--serial", default=None, metavar="PORT",
                       help="also drive a servo controller on this serial port "
                            "(protocol: imimic_gym/servo.py; sketch: firmware/servo_arm/)")
    mimic.add_argument("--baud", type=at_least(1), default=115200,
                       help="serial speed (default: %(default)s)")
    mimic.add_argument("--servo-range", type=float, nargs=2, default=(0.0, 120.0),
                       metavar=("LOW", "HIGH"),
                       help="the servo's angle range, degrees (default: 0 120)")
    mimic.add_argument("--servo-zero", type=float, default=60.0, metavar="DEG",
                       help="servo angle of joint angle 0 (default: %(default)s)")
    mimic.add_argument("--realtime", action="store_true",
                       help="play a file at its own frame rate rather than as fast as "
                            "possible (always on with --serial: the servo moves at the "
                            "person's speed)")
    mimic.add_argument("--preview-height", type=int, default=540, metavar="ROWS",
                       help="rows of mimic.mp4 for taller footage (default: %(default)s; the "
                            "estimator still reads full frames; 0 keeps the footage's size)")
    mimic.add_argument("--out", default="mimic_out", help="output folder (default: %(default)s)")
    mimic.set_defaults(func=cmd_mimic)


def _add_clip_choice(parser: argparse.ArgumentParser, names: list[str],
                     scenario: str) -> None:
    """--scenario, --seed and --frames: which rendered clip."""
    parser.add_argument("--scenario", default=scenario, choices=names,
                        help="which demonstrator clip (default: %(default)s)")
    parser.add_argument("--seed", type=int, default=0, help="clip seed (default: %(default)s)")
    parser.add_argument("--frames", type=at_least(2), default=None,
                        help="clip length in frames (default: the scenario's, 150 = 5 s)")


def build_parser() -> argparse.ArgumentParser:
    from imimic_gym.clips.scenarios import scenario_names

    parser = argparse.ArgumentParser(
        prog="imimic",
        description="Controlling by showing: a MuJoCo robot arm copies a human arm seen on "
                    "video (the i-Mimic paper as a Gymnasium toolkit).",
    )
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    names = scenario_names()

    demo = sub.add_parser(
        "demo", help="clip -> estimator -> robot arm; writes demo.mp4, angles.png, metrics.json",
        description="Run one scenario end to end, headless, and write into --out: demo.mp4 "
                    "(video and robot side by side), angles.png (human vs robot angle and the "
                    "error over time) and metrics.json (RMSE, max error, lag).",
    )
    _add_clip_choice(demo, names, "exp2-servo")
    demo.add_argument("--control", default="position", choices=("position", "velocity", "torque"),
                      help="robot actuation (default: %(default)s, the paper's servo)")
    demo.add_argument("--estimator", default=None, choices=estimator_names(),
                      help="where the robot's targets come from: DON on the video (1 to 3 "
                           "links), the CNN + refiner (a person's arm, 1 or 2 links), the "
                           "MOG2 or CamShift baseline (1 link), or the true angles (oracle: "
                           "the control loop's upper bound, no vision); default: don for 1 "
                           "or 2 links, oracle for the others")
    demo.add_argument("--out", default="demo_out", help="output folder (default: %(default)s)")
    demo.set_defaults(func=cmd_demo)

    clip = sub.add_parser(
        "clip", help="render a scenario to an mp4 plus a truth JSON",
        description="Render a scenario (or take it from the cache) and write "
                    "<scenario>-seed<k>.mp4 and .json with the per-frame ground truth: joint "
                    "angles, velocities, accelerations, keypoints, visibility, occlusion.",
    )
    _add_clip_choice(clip, names, "default")
    clip.add_argument("--out", default="clips_out", help="output folder (default: %(default)s)")
    clip.set_defaults(func=cmd_clip)

    add_eval(sub, names)

    scen = sub.add_parser("scenarios", help="list the named scenarios and their settings")
    scen.set_defaults(func=cmd_scenarios)

    add_cache(sub, names)

    bench = sub.add_parser(
        "bench", help="speed benchmarks, each against a reference measured in the same run",
        description="env: steps/s of ImitateVideo-v0 and of Gymnasium's Reacher-v5 in the same "
                    "run, and their ratio; plus clip rendering frames/s per scenario. "
                    "don: ms per frame of DON, the MOG2 and CamShift estimators and raw "
                    "OpenCV MOG2 at the paper's four resolutions (its Table 1), and plots of "
                    "time against N and detected area against light (its Fig. 3).",
    )
    bench.add_argument("what", choices=("env", "don"), help="which benchmark")
    bench.add_argument("--json", default=None, help="also write the results to this file")
    bench.add_argument("--steps", type=at_least(1), default=3000, help="steps per timed run")
    bench.add_argument("--repeats", type=at_least(1), default=5,
                       help="alternating timed runs per env")
    bench.set_defaults(func=cmd_bench)
    _add_mimic(sub)
    _add_label(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    from imimic_gym.clips.cache import CacheSettingError

    args = build_parser().parse_args(argv)
    try:
        return int(args.func(args))
    except CommandError as error:
        print(error, file=sys.stderr)
        raise
    except OSError as error:  # a folder or file the user named (--out, --video, ...)
        print(f"imimic {args.command}: {error}", file=sys.stderr)
        return 2
    except CacheSettingError as error:
        print(f"imimic {args.command}: {error}", file=sys.stderr)
        return 2

