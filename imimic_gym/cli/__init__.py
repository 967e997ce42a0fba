"""The `imimic` command: demo, clip, scenarios, eval, cache, bench, mimic, label."""

from __future__ import annotations

import argparse
import os
import select
import sys
from pathlib import Path
from typing import Any

import imimic_gym  # registers the env, sets headless GL; and its __version__
from imimic_gym._quiet_start import restore_ctrl_c
from imimic_gym.atomic import write_json
from imimic_gym.cli.cache import add_cache
from imimic_gym.cli.common import (
    CommandError,
    add_checkpoint,
    at_least,
    check_writable,
    checkpoint_params,
    estimator_names,
    print_table,
    save_json,
)
from imimic_gym.cli.evaluate import add_eval
from imimic_gym.cli.mimic import add_label, add_mimic
from imimic_gym.interrupts import CTRL_C, is_ctrl_c


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

    from imimic_gym.clips.video_writer import write_video
    from imimic_gym.controllers import EstimateTarget, OracleController, PDController
    from imimic_gym.plots import plot_tracking
    from imimic_gym.rollout import run_episode

    check_writable("demo", "--out", args.out, folder=True)
    params: dict[str, Any] = checkpoint_params("demo", [args.estimator], args.checkpoint)
    out = Path(args.out)
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
            env = RegistryObservation(env, args.estimator, keep_frame=False, **params)
        except UnsupportedClipError as error:
            raise CommandError(f"imimic demo: {error}") from error
        controller = PDController(env, EstimateTarget(env))
    trajectory = run_episode(env, controller, seed=args.seed, record=True)
    fps = float(env.metadata["render_fps"])
    env.close()
    out.mkdir(parents=True, exist_ok=True)
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
    write_json(out / "metrics.json", metrics)
    print(f"wrote {out / 'demo.mp4'}, {out / 'angles.png'}, {out / 'metrics.json'}")
    print_table(metrics)
    return 0


def cmd_clip(args: argparse.Namespace) -> int:
    from imimic_gym.clips.annotations import write_clip_truth
    from imimic_gym.clips.cache import load_clip
    from imimic_gym.clips.scenarios import get_scenario
    from imimic_gym.clips.video_writer import write_video

    overrides = {"seed": args.seed}
    if args.frames:
        overrides["n_frames"] = args.frames
    spec = get_scenario(args.scenario, **overrides)
    check_writable("clip", "--out", args.out, folder=True)
    out = Path(args.out)
    clip = load_clip(spec)
    out.mkdir(parents=True, exist_ok=True)
    stem = out / f"{args.scenario}-seed{args.seed}"
    write_video(stem.with_suffix(".mp4"), clip.frames, clip.fps)
    assert clip.truth is not None
    write_clip_truth(stem.with_suffix(".json"), clip.truth, clip.meta, clip.fps)
    print(f"wrote {stem.with_suffix('.mp4')} and {stem.with_suffix('.json')} "
          f"({len(clip)} frames, {clip.width}x{clip.height}, {clip.fps:g} fps)")
    return 0


def cmd_scenarios(args: argparse.Namespace) -> int:
    from dataclasses import asdict

    from imimic_gym.clips.scenarios import SCENARIOS

    for name, spec in sorted(SCENARIOS.items()):
        fields = {k: v for k, v in asdict(spec).items()
                  if k not in ("name", "seed") and not (k == "appearance" and v is None)}
        print(f"{name:20s} " + ", ".join(f"{k}={v}" for k, v in fields.items()))
    return 0


def cmd_bench(args: argparse.Namespace) -> int:
    from imimic_gym.bench import bench_env, bench_render, machine

    if args.what == "don" and args.steps is not None:
        raise CommandError("imimic bench don: --steps counts env steps per timed run; don "
                           "times each estimator on one fixed clip (--repeats sets how often)")
    check_writable("bench", "--json", args.json)
    result: dict[str, Any] = {"machine": machine()}
    if args.what == "don":
        return _bench_don(args, result)
    print("ImitateVideo-v0 vs Reacher-v5, steps/s (median of alternating runs)...")
    result.update(bench_env(**_given(args, "steps", "repeats")))
    print(f"  imitate {result['imitate_steps_per_s']:.0f}  reacher "
          f"{result['reacher_steps_per_s']:.0f}  ratio {result['ratio']:.2f} (target >= 0.5)")
    print("clip rendering at 240x320, frames/s, truth included, no cache...")
    result["render_frames_per_s"] = bench_render()
    for name, fps in result["render_frames_per_s"].items():
        print(f"  {name:20s} {fps:6.0f}")
    save_json(args.json, result)
    return 0


def _given(args: argparse.Namespace, *names: str) -> dict[str, Any]:
    """The options among ``names`` that the user gave (their defaults are None), as
    keyword arguments: the others keep the benchmark function's own defaults."""
    return {name: getattr(args, name) for name in names if getattr(args, name) is not None}


def _bench_don(args: argparse.Namespace, result: dict[str, Any]) -> int:
    from imimic_gym.bench import bench_don, don_window_and_lighting

    prefix = str(Path(args.json).with_suffix("")) if args.json else "bench_don"
    for figure in ("window", "lighting"):
        check_writable("bench", "the plot", f"{prefix}_{figure}.png")
    print("DON, baselines and raw OpenCV MOG2, CPU ms per frame on the same frames, "
          "1 thread...")
    result.update(bench_don(**_given(args, "repeats")))
    print(f"  {'resolution':11s} {'DON':>7s} {'paper':>7s} {'MOG2 est':>9s} {'CamShift':>9s} "
          f"{'MOG2 raw':>9s} {'DON/MOG2':>9s} {'paper/MOG2':>10s}")
    for row in result["rows"]:
        print(f"  {row['resolution']:11s} {row['don_ms']:7.2f} {row['don_paper_ms']:7.2f} "
              f"{row['mog2_estimator_ms']:9.2f} {row['camshift_estimator_ms']:9.2f} "
              f"{row['mog2_raw_ms']:9.2f} {row['ratio_mog2']:9.2f} "
              f"{row['ratio_mog2_paper']:10.2f}")
    print("  (paper: DON with the paper's layers only, without the appearance layer)")
    print("time against N and detected area against light (paper Fig. 3)...")
    Path(prefix).parent.mkdir(parents=True, exist_ok=True)  # checked above: it can be made
    result["figure3"] = don_window_and_lighting(prefix)
    print(f"  wrote {prefix}_window.png and {prefix}_lighting.png")
    save_json(args.json, result)
    return 0


def _add_clip_choice(parser: argparse.ArgumentParser, names: list[str],
                     scenario: str) -> None:
    """--scenario, --seed and --frames: which rendered clip."""
    parser.add_argument("--scenario", default=scenario, choices=names,
                        help="which demonstrator clip (default: %(default)s)")
    parser.add_argument("--seed", type=at_least(0), default=0,
                        help="clip seed, 0 or more (default: %(default)s)")
    parser.add_argument("--frames", type=at_least(2), default=None,
                        help="clip length in frames (default: the scenario's, 150 = 5 s)")


def build_parser() -> argparse.ArgumentParser:
    from imimic_gym.clips.scenarios import scenario_names

    parser = argparse.ArgumentParser(
        prog="imimic",
        description="Controlling by showing: a MuJoCo robot arm copies a human arm seen on "
                    "video (the i-Mimic paper as a Gymnasium toolkit).",
    )
    parser.add_argument("--version", action="version",
                        version=f"imimic_gym {imimic_gym.__version__}")
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
                           "MOG2 or CamShift baseline (1 link), the pose model (pose, "
                           "pose-don: a real person's arm, so not the servo), or the true "
                           "angles (oracle: the control loop's upper bound, no vision); "
                           "default: don for 1 or 2 links, oracle for the others")
    add_checkpoint(demo)
    demo.add_argument("--out", default="demo_out", help="output folder (default: %(default)s)")
    demo.set_defaults(func=cmd_demo)

    clip = sub.add_parser(
        "clip", help="render a scenario to an mp4 plus a truth JSON",
        description="Render a scenario (or take it from the cache) and write "
                    "<scenario>-seed<k>.mp4 and .json with the per-frame ground truth: joint "
                    "angles, velocities, accelerations, keypoints, visibility, occlusion. "
                    "ImitateVideo-v0(clip=<the mp4>, annotations=<the json>) reads them "
                    "back.",
    )
    _add_clip_choice(clip, names, "default")
    clip.add_argument("--out", default="clips_out", help="output folder (default: %(default)s)")
    clip.set_defaults(func=cmd_clip)

    add_eval(sub, names)

    scen = sub.add_parser(
        "scenarios", help="list the named scenarios and their settings",
        description="List every named scenario (--scenario of demo, clip, eval and cache) "
                    "with what it renders: demonstrator, links, motion, background, "
                    "occluder, size and length. The paper's experiments are exp1 to exp4.")
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
    bench.add_argument("--steps", type=at_least(1), default=None,
                       help="env only: steps per timed run (default: 3000)")
    bench.add_argument("--repeats", type=at_least(1), default=None,
                       help="alternating timed runs, of which the median is reported: per "
                            "env (env, default: 5), or per estimator and resolution (don's "
                            "table, default: 7)")
    bench.set_defaults(func=cmd_bench)
    add_mimic(sub)
    add_label(sub)
    for command in sub.choices.values():
        command.add_argument("--verbose", action="store_true",
                             help="also show the log lines of native code (MediaPipe's pose "
                                  "model, OpenCV's FFmpeg) on stderr")
    return parser


# Exit code when the reader of the output went away (`imimic scenarios | head -1`): what a
# shell reports for Unix tools that SIGPIPE ends, 128 + 13, so `set -o pipefail` sees the
# same as for them.
STOPPED_READING = 141


def _output_closed() -> bool:
    """Whether standard output is a pipe whose reader has gone (another pipe may have
    broken); if so, standard output is pointed at the null device, so that Python's flush
    at exit does not fail again on what is still buffered for it."""
    try:
        fd = sys.stdout.fileno()
        poller = select.poll()
    except (AttributeError, OSError, ValueError):  # no file descriptor, or no poll()
        return False
    poller.register(fd, select.POLLOUT)
    if not any(events & select.POLLERR for _, events in poller.poll(0)):
        return False
    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, fd)
    os.close(devnull)
    return True


def main(argv: list[str] | None = None) -> int:
    from imimic_gym.clips.cache import CacheSettingError

    command = "imimic"
    try:
        restore_ctrl_c()  # a Ctrl-C from here on is caught below
        args = build_parser().parse_args(argv)
        args.argv = list(sys.argv[1:] if argv is None else argv)  # as given, to repeat it
        command = f"imimic {args.command}"
        if args.verbose:  # read by the pose model and the video reader (estimators.pose_model)
            os.environ["IMIMIC_NATIVE_LOGS"] = "1"
        return int(args.func(args))
    except CommandError as error:
        print(error, file=sys.stderr)
        raise
    except BrokenPipeError as error:  # whoever read the output stopped (| head): no error
        if not _output_closed():
            print(f"{command}: {error}", file=sys.stderr)
            return 2
        return STOPPED_READING
    except OSError as error:  # a folder or file the user named (--out, --video, ...)
        print(f"{command}: {error}", file=sys.stderr)
        return 2
    except CacheSettingError as error:
        print(f"{command}: {error}", file=sys.stderr)
        return 2
    except CTRL_C as error:  # commands that keep partial work catch it themselves
        if not is_ctrl_c(error):
            raise
        print(f"{command}: stopped by Ctrl-C", file=sys.stderr)
        return 130

