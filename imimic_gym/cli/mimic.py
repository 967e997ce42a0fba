"""`imimic mimic` (a robot arm copies the arm in a video or a camera) and `imimic label`
(the pose model's labels of a video, for correcting and training)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any, cast

from imimic_gym.cli.common import (
    CommandError,
    add_checkpoint,
    at_least,
    check_writable,
    checkpoint_params,
    estimator_names,
    finite,
    positive,
    print_table,
    unit_interval,
)

# What `imimic mimic` runs unless told: it finds a person and their moving arm by itself;
# with --robot, it reads that arm in 3-D.
MIMIC_ESTIMATOR = "pose"
SPATIAL_ESTIMATOR = "pose3d"


def cmd_mimic(args: argparse.Namespace) -> int:
    """`imimic mimic`; footage that cannot be used is reported in one line (exit code 2)."""
    from imimic_gym.clips.video import VideoFormatError, VideoOpenError
    from imimic_gym.estimators.registry import get_estimator

    spatial = args.robot is not None
    if args.estimator is None:
        args.estimator = SPATIAL_ESTIMATOR if spatial else MIMIC_ESTIMATOR
    entry = get_estimator(args.estimator)
    if entry.spatial and not spatial:
        raise CommandError(f"imimic mimic: {args.estimator} reads the arm in 3-D; give "
                           f"--robot so101 for a robot that moves in space (the planar arm "
                           f"copies planar estimators' joint angles)")
    if spatial and not entry.spatial:
        raise CommandError(f"imimic mimic: --robot {args.robot} copies an arm read in 3-D; "
                           f"{args.estimator} reads angles in the image plane (use pose3d, "
                           f"the default with --robot, or pose-world)")
    _check_robot_options(args)
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
    if args.camera is not None and not (args.camera.isdigit() or "://" in args.camera
                                        or Path(args.camera).exists()):
        raise CommandError(f"imimic mimic: --camera takes a camera index (0, 1, ...) or a "
                           f"stream URL (rtsp://...) or a device (/dev/video0), got "
                           f"{args.camera!r}")
    check_writable("mimic", "--out", args.out, folder=True)
    checkpoint_params("mimic", [args.estimator], args.checkpoint)
    try:
        return _mimic(args)
    except (VideoOpenError, VideoFormatError) as err:
        print(f"imimic mimic: {err}", file=sys.stderr)
        return 2


def _check_robot_options(args: argparse.Namespace) -> None:
    """The real arm's options belong together: --port or --dry-run need --robot and a
    calibration; the planar arm's own options are not the SO-101's."""
    spatial = args.robot is not None
    bus = args.port is not None or args.dry_run
    if not spatial:
        for option, given in (("--port", args.port is not None), ("--dry-run", args.dry_run),
                              ("--mapping", args.mapping != "mirror"),
                              ("--fov", args.fov is not None),
                              ("--calibration", args.calibration is not None),
                              ("--robot-id", args.robot_id is not None)):
            if given:
                raise CommandError(f"imimic mimic: {option} goes with --robot so101 (the "
                                   f"SO-101, simulated and, with --port, real)")
        return
    for option, given in (("--serial", args.serial is not None), ("--links", args.links != 1),
                          ("--joint-range", args.joint_range is not None),
                          ("--control", args.control != "position"),
                          ("--pivot", args.pivot is not None)):
        if given:
            raise CommandError(f"imimic mimic: {option} is the planar arm's; with --robot "
                               f"{args.robot} the arm is read in 3-D (--port drives the real "
                               f"SO-101)")
    if args.fov is not None and not 10.0 <= args.fov <= 170.0:
        raise CommandError(f"imimic mimic: --fov takes the camera's field of view across the "
                           f"image's longer side, 10 to 170 degrees, got {args.fov:g}")
    if bus and args.calibration is None and args.robot_id is None:
        raise CommandError("imimic mimic: the SO-101's bus needs its LeRobot calibration: "
                           "--calibration FILE.json or --robot-id ID (the id you calibrated "
                           "it under with lerobot-calibrate)")
    if not bus and (args.calibration is not None or args.robot_id is not None):
        raise CommandError("imimic mimic: --calibration and --robot-id calibrate the real "
                           "arm: give --port PORT (or --dry-run) with them")


def _open_bus(args: argparse.Namespace) -> Any:
    """The SO-101's bus, connected (nothing is written before every servo answered), or
    None without --port/--dry-run. Problems are one line (`CommandError`)."""
    if args.port is None and not args.dry_run:
        return None
    from imimic_gym.hardware import (
        BusError,
        CalibrationError,
        SO101Bus,
        find_calibration,
        load_calibration,
    )

    try:
        calibration = (load_calibration(args.calibration) if args.calibration is not None
                       else find_calibration(args.robot_id))
    except CalibrationError as error:
        raise CommandError(f"imimic mimic: {error}") from None
    log = None
    if args.dry_run:  # the packets go to a file, not through the progress bar
        Path(args.out).mkdir(parents=True, exist_ok=True)
        log = (Path(args.out) / "bus.log").open("w", buffering=1)
    try:
        bus = SO101Bus(args.port or "(dry run)", calibration, max_step_deg=args.max_step_deg,
                       on_exit=args.on_exit, dry_run=log or False)
        bus.connect()
    except (BusError, ValueError) as error:
        if log is not None:
            log.close()
        raise CommandError(f"imimic mimic: {error}") from None
    where = (f"a dry run: the packets go to {Path(args.out) / 'bus.log'}" if args.dry_run
             else args.port)
    print(f"  SO-101 on {where}; at most {args.max_step_deg:g} degrees a frame; on exit, "
          f"{args.on_exit}")
    return bus


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
        from imimic_gym.estimators.pose.planar import human_joint_ranges

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
    if args.fov is not None:  # the camera the 3-D reading assumes (else a guessed one)
        from dataclasses import asdict

        from imimic_gym.spatial.camera import Intrinsics

        clip.meta["intrinsics"] = asdict(Intrinsics.from_fov(args.fov, clip.width,
                                                             clip.height))
    if args.robot is not None:  # the footage opened: now the arm, which then holds
        try:
            servo = _open_bus(args)
        except BaseException:
            frames.close()
            raise
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
    if args.checkpoint is not None:
        params["checkpoint"] = args.checkpoint
    summary = run_mimic(clip, args.out, estimator=args.estimator, control=args.control,
                        estimator_params=params, servo=servo,
                        realtime=not live and (args.realtime or (
                            servo is not None and not args.dry_run)),
                        preview_height=args.preview_height or None, robot=args.robot,
                        mapping=args.mapping)
    out = Path(args.out)
    print(f"{summary['ended']}: wrote {out / 'mimic.mp4'}, {out / 'angles.png'}, "
          f"{out / 'mimic.csv'}, {out / 'mimic.json'}")
    print_table({k: v for k, v in summary.items() if k not in ("source",)})
    if summary["ended"].startswith("stopped: "):  # the robot's port was lost mid-run
        print(f"imimic mimic: {summary['ended']}", file=sys.stderr)
        return 1
    # Stopped early, as every command stopped by Ctrl-C: not the success a following
    # command expects.
    return 130 if summary["ended"] == "stopped by Ctrl-C" else 0


def cmd_label(args: argparse.Namespace) -> int:
    """`imimic label`: the pose model's labels of a video, as COCO keypoints."""
    from imimic_gym.clips.video import VideoFormatError, VideoOpenError
    from imimic_gym.labels import label_video

    check_writable("label", "--out", args.out, folder=True)
    try:
        summary = label_video(args.video, args.out, arm=args.arm,
                              min_confidence=args.min_confidence, fps=args.fps)
    except (VideoOpenError, VideoFormatError, OSError) as err:
        print(f"imimic label: {err}", file=sys.stderr)
        return 2
    if summary["ended"] != "end of footage":
        print(f"imimic label: {summary['ended']}", file=sys.stderr)
    wrote = f"wrote {summary['labels']} and {summary['images']}/"
    if summary["labelled"]:
        print(f"labelled {summary['labelled']} of {summary['frames']} frames: {wrote} "
              f"({_training_hint(summary['labels'], summary['images'])})")
    else:
        print(f"labelled 0 of {summary['frames']} frames: the pose model found no arm with "
              f"shoulder, elbow and wrist all at --min-confidence {args.min_confidence:g} or "
              f"more; {wrote}, nothing to train on (footage with the person's arm in view, "
              "or a lower --min-confidence)")
    # Stopped early, the labels are partial: not the success a following command expects.
    return 130 if summary["ended"] == "stopped by Ctrl-C" else 0


def _training_hint(labels: str, images: str) -> str:
    """How to train the CNN on ``labels``: the training script where this package sits in
    the project's source; from a wheel, which has no training/, where to get it."""
    import imimic_gym

    options = f"--annotations {labels} --images {images} --split time"
    script = Path(imimic_gym.__file__).resolve().parents[1] / "training" / "train_cnn.py"
    if script.is_file():
        try:
            shown = script.relative_to(Path.cwd())
        except ValueError:
            shown = script
        return f"train: python {shown} {options}"
    return ("train: training/train_cnn.py comes with the project's source, not with the "
            "installed package; in a clone of the project's repository run python "
            f"training/train_cnn.py {options}")


def add_label(sub: argparse._SubParsersAction) -> None:
    label = sub.add_parser(
        "label", help="label a video's arm with the pose model (COCO keypoints, for CVAT, "
                      "Label Studio and train_cnn.py)",
        description="Run the pretrained pose model over a video and write --out/images/ "
                    "(every frame as JPEG) and --out/labels.json (COCO keypoints, one 'arm' "
                    "category: shoulder, elbow, wrist; an annotation on each frame where "
                    "all three reach --min-confidence, the others left unlabelled). CVAT and "
                    "Label Studio import it for a person to correct; training/train_cnn.py "
                    "--annotations --images --split time (in the project's source, not the "
                    "installed package) trains the CNN on it; ImitateVideo-v0("
                    "clip=VIDEO, annotations=labels.json) scores on it.",
    )
    label.add_argument("--video", required=True, metavar="FILE",
                       help="a recorded video (anything OpenCV reads) or an image pattern")
    label.add_argument("--out", default="labels_out", help="output folder (default: "
                                                           "%(default)s)")
    label.add_argument("--fps", type=positive, default=None,
                       help="frame rate of a source that reports none (an image pattern)")
    label.add_argument("--arm", default="auto", choices=("auto", "left", "right"),
                       help="the person's arm to label (default: auto, the one that moves)")
    label.add_argument("--min-confidence", type=unit_interval, default=0.5,
                       help="label a frame when shoulder, elbow and wrist all reach this "
                            "confidence (default: %(default)s)")
    label.set_defaults(func=cmd_label)


def add_mimic(sub: argparse._SubParsersAction) -> None:
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
                            "latency, stops on Ctrl-C or when the camera disappears; frames "
                            "that queue up (while the models load, or behind a slower "
                            "machine) are passed over, so the robot follows the picture of "
                            "now")
    mimic.add_argument("--estimator", default=None,
                       choices=estimator_names(video_only=True),
                       help=f"the vision estimator (default: {MIMIC_ESTIMATOR}, which finds a "
                            f"person by itself, or {SPATIAL_ESTIMATOR} with --robot, which "
                            f"reads their arm in 3-D; don is the paper's, for a lone moving "
                            f"link such as the servo)")
    robot = mimic.add_argument_group(
        "a robot arm in space (docs: README, 'Drive your SO-101')")
    robot.add_argument("--robot", default=None, choices=("so101",),
                       help="copy the arm read in 3-D onto this robot (default: the planar "
                            "arm of the image plane); the SO-101's joint targets go into "
                            "mimic.csv in LeRobot's names and units")
    from imimic_gym.retarget.mapping import MAPPINGS

    robot.add_argument("--mapping", default="mirror", choices=tuple(MAPPINGS),
                       help="how the person's arm maps onto the robot: " + "; ".join(
                           f"{name}: {m.description}" for name, m in MAPPINGS.items())
                       + " (default: %(default)s)")
    robot.add_argument("--fov", type=finite, default=None, metavar="DEG",
                       help="the camera's field of view across the image's longer side "
                            "(horizontal for landscape video; not the diagonal that some "
                            "webcams list), degrees, 10 to 170: the 3-D reading's "
                            "perspective (default: 60, a typical webcam or phone, for "
                            "footage whose camera is unknown)")
    robot.add_argument("--port", default=None, metavar="PORT",
                       help="also drive the real SO-101 on its bus adapter's port "
                            "(/dev/ttyACM0): goal positions through your LeRobot "
                            "calibration, at the footage's own speed")
    robot.add_argument("--calibration", default=None, metavar="FILE",
                       help="the arm's LeRobot calibration JSON (or --robot-id)")
    robot.add_argument("--robot-id", default=None, metavar="ID",
                       help="the id the arm was calibrated under with lerobot-calibrate; "
                            "its file is found where LeRobot keeps it")
    robot.add_argument("--max-step-deg", type=positive, default=4.0, metavar="DEG",
                       help="most a joint's goal moves per frame, motor degrees (default: "
                            "%(default)s, 120 degrees/s at 30 frames/s)")
    robot.add_argument("--on-exit", default="torque-off", choices=("torque-off", "hold"),
                       help="at the end, on Ctrl-C and on any error: release the servos "
                            "(the arm goes limp) or hold the last pose (default: "
                            "%(default)s)")
    robot.add_argument("--dry-run", action="store_true",
                       help="open no port: write the packets the bus would get (hex and "
                            "meaning) into --out/bus.log, the arm taken at the middle of "
                            "each range")
    mimic.add_argument("--links", type=int, default=1,
                       help="moving links to copy, a chain (default: %(default)s; DON "
                            "handles 1 to 3, the CNN 1 or 2)")
    mimic.add_argument("--control", default="position",
                       choices=("position", "velocity", "torque"),
                       help="robot actuation (default: %(default)s, the paper's servo)")
    mimic.add_argument("--reference-direction", type=finite, default=-90.0, metavar="DEG",
                       help="image direction of the fixed reference link, degrees CCW from "
                            "image right (default: %(default)s = image down)")
    mimic.add_argument("--joint-range", type=finite, nargs=2, default=None,
                       metavar=("LOW", "HIGH"),
                       help="the robot's joint range in degrees from the reference (default: "
                            "a human arm's for the estimators that find a person, -175 175 "
                            "at the elbow; the paper's 120-degree servo, -60 60, for the "
                            "others)")
    mimic.add_argument("--arm", default="auto", choices=("auto", "left", "right"),
                       help="which of the person's arms to copy (their own left or right; "
                            "default: auto, the arm that moves)")
    add_checkpoint(mimic)
    mimic.add_argument("--pivot", type=finite, nargs=2, default=None, metavar=("X", "Y"),
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
    mimic.add_argument("--servo-range", type=finite, nargs=2, default=(0.0, 120.0),
                       metavar=("LOW", "HIGH"),
                       help="the servo's angle range, degrees (default: 0 120)")
    mimic.add_argument("--servo-zero", type=finite, default=60.0, metavar="DEG",
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
