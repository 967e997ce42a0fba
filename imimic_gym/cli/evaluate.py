"""`imimic eval`: estimators alone, the tracking suite or the paper's experiments on
held-out clips, or estimators on annotated photos; here or as a sweep on Ray."""

from __future__ import annotations

import argparse
import shlex
import sys
from collections.abc import Iterable
from pathlib import Path

import numpy as np

from imimic_gym.atomic import write_text
from imimic_gym.cli.common import (
    CommandError,
    add_backend,
    add_checkpoint,
    add_clip_seeds,
    at_least,
    check_backend,
    check_writable,
    checkpoint_params,
    estimator_names,
    save_json,
)
from imimic_gym.interrupts import CTRL_C, is_ctrl_c

# The defaults of the options one mode takes and another refuses: None in argparse, so
# that an option the user gave is told from one left out.
DEFAULTS = {"scenario": ["exp2-servo"], "estimator": ["don"], "modality": "rgb",
            "out": "eval_out"}


def cmd_eval(args: argparse.Namespace) -> int:
    try:
        return _eval(args)
    except SweepStopped:
        return 130


def _eval(args: argparse.Namespace) -> int:
    _refuse_ignored(args)
    for name, value in DEFAULTS.items():
        if getattr(args, name) is None:
            setattr(args, name, value)
    _check_outputs(args)
    sweep = args.backend == "ray" or args.results is not None
    if sweep and args.checkpoint:
        raise CommandError("imimic eval: --checkpoint runs here; --backend ray and --results "
                           "run the shipped weights")
    args.estimator_params = checkpoint_params("eval", args.estimator, args.checkpoint)
    if args.photos or args.images:
        if sweep:
            raise CommandError("imimic eval: --photos runs here; --backend ray and --results "
                               "are for clips")
        return _cmd_eval_photos(args)
    check_backend(args, "eval")
    if args.resume and args.results is None:
        raise CommandError("imimic eval: --resume needs --results FILE, the journal of the "
                           "sweep to resume")
    if sweep and args.num_envs > 1:
        raise CommandError("imimic eval: --num-envs steps clips together in one run; a "
                           "sweep (--backend ray or --results) runs one cell per clip instead")
    if args.paper or args.controller:
        return _cmd_eval_suite(args, sweep)
    _refuse_unscorable(args)
    if sweep:
        from imimic_gym.sweep import Cell

        cells = [Cell(scenario, estimator, None, seed, args.frames, args.modality)
                 for scenario in args.scenario for estimator in args.estimator
                 for seed in _seeds(args)]
        results, failed, _ = _run_sweep(cells, args)
        for result in results:
            _print_estimator_result(result)
        save_json(args.json, results)
        return _report_failures(failed, args)
    results, stopped = _score_alone(args)
    if results or not stopped:  # a Ctrl-C before any result leaves earlier files alone
        save_json(args.json, results)
    return _stopped_by_ctrl_c(len(results)) if stopped else 0


def _score_alone(args: argparse.Namespace) -> tuple[list[dict], bool]:
    """Each estimator on each scenario's clips here (`evaluation.evaluate_clip`), each
    result printed as it finishes: the results, and whether Ctrl-C stopped them (the last
    result is then over the clips that had finished, if any had)."""
    from imimic_gym.evaluation import evaluate_clip, summarise_estimator

    rows: dict[tuple[str, str], list[dict]] = {}  # one try around all: no gap for Ctrl-C

    def result(pair: tuple[str, str]) -> dict:
        return summarise_estimator(*pair, args.modality, rows[pair])

    try:
        for pair in ((s, e) for s in args.scenario for e in args.estimator):
            for seed in _seeds(args):
                row = evaluate_clip(*pair, seed, args.modality, args.frames,
                                    args.estimator_params)
                rows.setdefault(pair, []).append(row)
            _print_estimator_result(result(pair))
    except CTRL_C as error:
        if not is_ctrl_c(error):
            raise
        unfinished = [pair for pair in rows if len(rows[pair]) < args.episodes]
        for pair in unfinished:
            _print_estimator_result(result(pair), f"partial: stopped by Ctrl-C, "
                                                  f"{len(rows[pair])} of {args.episodes} clips")
        return [result(pair) for pair in rows], True
    return [result(pair) for pair in rows], False


def _until_ctrl_c(items: Iterable, into: list) -> bool:
    """Append ``items`` to ``into`` as they come; True if Ctrl-C stopped them first."""
    try:
        for item in items:
            into.append(item)
    except CTRL_C as error:
        if not is_ctrl_c(error):
            raise
        return True
    return False


def _stopped_by_ctrl_c(finished: int) -> int:
    """Exit code 130, saying what was kept (printed, and written where asked)."""
    print(f"imimic eval: stopped by Ctrl-C; kept the {finished} results that had finished",
          file=sys.stderr)
    return 130


def _refuse_ignored(args: argparse.Namespace) -> None:
    """Refuse, naming them, the options the user gave that the chosen mode would ignore
    (options that are None or False were not given)."""
    ignored: tuple[str, ...]
    if args.photos or args.images:
        mode = "--photos scores estimators on single photos"
        ignored = ("scenario", "controller", "paper", "modality", "frames", "out")
    elif args.paper:
        mode = "--paper runs the paper's own scenarios, estimators and controllers"
        ignored = ("scenario", "estimator", "controller", "modality", "checkpoint")
    elif args.controller:
        mode = "--controller runs the tracking suite on the colour video"
        ignored = ("modality",)
    else:
        mode = "without --controller or --paper, estimators are scored alone (into --json)"
        ignored = ("out",)
    given = [f"--{name}" for name in ignored if getattr(args, name) not in (None, False)]
    if given:
        raise CommandError(f"imimic eval: {mode}; it does not take {', '.join(given)}")


def _check_outputs(args: argparse.Namespace) -> None:
    """Refuse outputs that cannot be written before any clip runs, so that no result is
    computed and then lost: --json, --results and, for the suite, --out with eval.md
    and plots/ in it."""
    check_writable("eval", "--json", args.json)
    check_writable("eval", "--results", args.results)
    if args.paper or args.controller:
        out = Path(args.out)
        check_writable("eval", "--out", args.out, folder=True)
        check_writable("eval", "--out", str(out / "plots"), folder=True)
        check_writable("eval", "--out", str(out / "eval.md"))


def _refuse_unscorable(args: argparse.Namespace) -> None:
    """Before any clip runs, refuse an estimator that cannot be scored on a scenario
    asked for (`evaluation.cannot_score`), naming the pair and why."""
    from imimic_gym.evaluation import cannot_score

    for scenario in args.scenario:
        for estimator in args.estimator:
            why = cannot_score(scenario, estimator, args.modality)
            if why:
                raise CommandError(f"imimic eval: {scenario!r}: {why}")


def _seeds(args: argparse.Namespace) -> tuple[int, ...]:
    return tuple(range(args.first_seed, args.first_seed + args.episodes))


def _print_estimator_result(result: dict, partial: str = "") -> None:
    """One row of an estimator's scores; ``partial``: why it covers fewer clips, marked
    at its end."""
    mean = result["mean"]
    if "elbow_flexion_rmse_deg" in mean or "coverage" in mean:  # a spatial estimator
        print(f"{result['scenario']:20s} {result['estimator']:12s} elbow flexion rmse "
              f"{_shown(mean.get('elbow_flexion_rmse_deg'), 2):>6s} deg, forearm direction "
              f"{_shown(mean.get('forearm_direction_error_deg'), 2):>6s} deg (median), upper "
              f"arm {_shown(mean.get('upper_arm_direction_error_deg'), 2):>6s} deg, coverage "
              f"{mean['coverage']:.2f}", flush=True)
        return
    occluded = ""
    if "rmse_occluded_deg_prediction_on" in mean:
        occluded = (f"  occluded: {mean['rmse_occluded_deg_prediction_off']:.1f} "
                    f"(prediction off) / {mean['rmse_occluded_deg_prediction_on']:.1f} (on)")
    within = ""
    if mean["rmse_deg_settled"] is None:
        within = f" (the clips end within the {result['warm_up_s']:g} s warm-up)"
    print(f"{result['scenario']:20s} {result['estimator']:9s} rmse {mean['rmse_deg']:6.2f} "
          f"deg, settled {_shown(mean['rmse_deg_settled'], 2):>6s} deg, lag "
          f"{_shown(mean['lag_frames'], 1):>5s} frames, eta {mean['mean_trust']:.2f}"
          f"{occluded}{within}{f' ({partial})' if partial else ''}", flush=True)


def _shown(value: float | None, digits: int) -> str:
    """``value`` with ``digits`` decimals, or "-" for a figure that does not exist."""
    return "-" if value is None else f"{value:.{digits}f}"


def _run_sweep(cells: list, args: argparse.Namespace) -> tuple[list[dict], dict, dict]:
    """Run ``cells`` as a sweep (`sweep.run_sweep`): the results per configuration, the
    failed cells' errors and each finished cell's row. Ctrl-C raises `SweepStopped`,
    having said how many cells had finished and how to go on."""
    from imimic_gym.backends import BackendError
    from imimic_gym.sweep import SweepError, SweepInterrupted, run_sweep, summaries

    try:
        outcome = run_sweep(cells, journal=args.results, resume=args.resume,
                            backend=args.backend, address=args.address)
    except (BackendError, SweepError) as error:
        raise CommandError(f"imimic eval: {error}") from error
    except SweepInterrupted as stop:
        finished = f"{len(stop.result.rows)} of {len(cells)} cells had finished"
        if args.results:
            again = [*args.argv, *([] if args.resume else ["--resume"])]
            print(f"imimic eval: stopped by Ctrl-C; {finished}, kept in {args.results}; go "
                  f"on with:\n  {shlex.join(['imimic', *again])}", file=sys.stderr)
        else:
            print(f"imimic eval: stopped by Ctrl-C; {finished}, not kept (--results FILE "
                  "keeps each cell as it finishes, so that --resume can go on)",
                  file=sys.stderr)
        raise SweepStopped from stop
    skipped = len(cells) - len(outcome.computed)
    if skipped:
        print(f"{skipped} of {len(cells)} cells taken from {args.results}")
    return summaries(cells, outcome.rows), outcome.failures, outcome.rows


class SweepStopped(Exception):
    """Ctrl-C stopped a sweep; what was kept is said: the command ends with code 130."""


def _report_failures(failed: dict, args: argparse.Namespace) -> int:
    """Exit code 1 and the failed cells by name (their errors are in the journal)."""
    if not failed:
        return 0
    print(f"{len(failed)} cells failed (the others' results are kept"
          + ("; rerun with --resume to retry only them" if args.results else "") + "):")
    for cell, error in failed.items():
        print(f"  {cell.name}: {error}")
    return 1


def _cell(item: dict) -> str:
    """"value (low-high)" of a `metrics.with_interval` result."""
    if item["value"] is None:
        return "-"
    return f"{item['value']:.2f} ({item['low']:.2f}-{item['high']:.2f})"


def _cmd_eval_photos(args: argparse.Namespace) -> int:
    """`imimic eval --photos F --images DIR`: PCP and elbow error on annotated photos."""
    from imimic_gym.clips.annotations import AnnotationError
    from imimic_gym.evaluation import evaluate_photos

    if not (args.photos and args.images):
        raise CommandError("imimic eval: --photos (a COCO-keypoints file) and --images (the "
                         "folder of its photos) go together")
    results = []
    for estimator in args.estimator:
        try:
            result = evaluate_photos(args.photos, args.images, estimator,
                                     **args.estimator_params)
        except (ValueError, AnnotationError, FileNotFoundError) as error:
            raise CommandError(f"imimic eval: {error}") from error
        print(f"{estimator:10s} PCP@0.5 upper {_cell(result['pcp_upper'])}, lower "
              f"{_cell(result['pcp_lower'])}; elbow error median "
              f"{_cell(result['elbow_error_deg_median'])} deg; keypoints on "
              f"{result['found']} of {result['photos']} photos (95% bootstrap intervals)",
              flush=True)
        results.append(result)
    save_json(args.json, results)
    return 0


def _suite_table(results: list[dict]) -> str:
    """Markdown table of the suite's means, one row per scenario x estimator x controller."""
    lines = ["| scenario | estimator | controller | RMSE (deg) | max (deg) | lag (frames) | "
             "jerk (deg/s^3) | recovery (s) | mean eta | seeds |", "|" + "---|" * 10]
    for r in results:
        m = r["mean"]
        lines.append(
            f"| `{r['scenario']}` | {r['estimator']} | {r['controller']} | "
            f"{m['rmse_deg']:.2f} | {m['max_error_deg']:.1f} | {m['lag_frames']:.1f} | "
            f"{_shown(m['jerk_deg_s3'], 0)} | {_shown(m['recovery_s'], 2)} | "
            f"{_shown(m['mean_trust'], 2)} | {r['episodes']} |")
    return "\n".join(lines)


def _suite_configs(args: argparse.Namespace) -> list:
    """The suite's runs: the paper's, or scenarios x controllers x estimators (less the
    combinations that cannot run, said in one line; one run of the oracle controller).
    Nothing left to run is a user error."""
    from imimic_gym.clips.scenarios import get_scenario
    from imimic_gym.evaluation import cannot_score
    from imimic_gym.paper import paper_configs
    from imimic_gym.suite import RunConfig

    seeds = _seeds(args)
    if args.paper:
        return paper_configs(seeds, args.frames)
    configs, skipped = [], []
    for scenario in args.scenario:
        spec = get_scenario(scenario)
        # The shipped planar policy drives one link; the 3-D one, the SO-101's six joints.
        learned_cannot = spec.n_links != 1 and not spec.spatial
        for controller in args.controller:
            for estimator in args.estimator:
                if (cannot_score(scenario, estimator, controlled=True)
                        or (learned_cannot and controller == "learned")):
                    skipped.append(f"{scenario}/{estimator}/{controller}")
                    continue
                configs.append(RunConfig(scenario, estimator, controller, seeds, args.frames,
                                         tuple(args.estimator_params.items())))
                if controller == "oracle":
                    break  # the oracle controller ignores the estimate: one run is enough
    if skipped:
        why = ("estimators that cannot follow the scenario's clips, for their links or "
               "demonstrator, and the learned policy on a planar arm beyond one link")
        if not configs:
            raise CommandError(f"imimic eval: nothing to run: {', '.join(skipped)} "
                               f"cannot run ({why})")
        print(f"skipped ({why}): " + ", ".join(skipped))
    return configs


def _cmd_eval_suite(args: argparse.Namespace, sweep: bool) -> int:
    """`imimic eval --controller ...` or `--paper`: the tracking suite."""
    from imimic_gym.paper import paper_table
    from imimic_gym.plots import plot_tracking
    from imimic_gym.rollout import Trajectory
    from imimic_gym.suite import iter_suite

    configs = _suite_configs(args)
    out = Path(args.out)
    (out / "plots").mkdir(parents=True, exist_ok=True)

    def plot(config, trajectory: Trajectory) -> None:
        name = f"{config.scenario}__{config.estimator}__{config.controller}"
        plot_tracking(trajectory, out / "plots" / f"{name}.png",
                      title=f"{config.scenario}, seed {config.seeds[0]}: {config.estimator} "
                            f"+ {config.controller}")

    failed: dict = {}
    stopped = False
    if sweep:
        from imimic_gym.sweep import Cell

        cells = [Cell(c.scenario, c.estimator, c.controller, seed, c.frames,
                      trajectory=seed == c.seeds[0]) for c in configs for seed in c.seeds]
        results, failed, rows = _run_sweep(cells, args)
        for cell in cells:
            series = rows.get(cell, {}).get("trajectory") if cell.trajectory else None
            if series is not None:
                config = next(c for c in configs if (c.scenario, c.estimator, c.controller)
                              == (cell.scenario, cell.estimator, cell.controller))
                trust = series["trust"]
                plot(config, Trajectory(
                    time=np.asarray(series["time"]), target=np.asarray(series["target"]),
                    robot=np.asarray(series["robot"]), reward=np.asarray(series["reward"]),
                    occlusion=np.asarray(series["occlusion"]),
                    trust=None if trust is None else np.asarray(trust)))
    else:
        results = []
        stopped = _until_ctrl_c(iter_suite(configs, num_envs=args.num_envs,
                                           on_trajectory=plot), results)
    if stopped and not results:  # nothing finished: earlier files are left alone
        return _stopped_by_ctrl_c(0)
    table = _suite_table(results)
    if args.paper:
        table = paper_table(results) + "\n\n" + table
    print(table)
    write_text(out / "eval.md", table + "\n")
    print(f"wrote {out / 'eval.md'} and {len(results)} plots in {out / 'plots'}")
    save_json(args.json, results)
    return _stopped_by_ctrl_c(len(results)) if stopped else _report_failures(failed, args)


def add_eval(sub: argparse._SubParsersAction, names: list[str]) -> None:
    evaluate = sub.add_parser(
        "eval", help="score estimators, or estimator + controller pairs, on held-out clips",
        description="Without --controller: run each estimator over held-out clips (seeds from "
                    "--first-seed) of each scenario and print the angle RMSE (all frames, and "
                    "after 0.5 s of warm-up: frame differencing sees nothing before the arm "
                    "moves), lag, mean trust factor, and for occluded frames the RMSE with "
                    "DON's prediction layer off and on. With --controller: the tracking suite, "
                    "scenarios x estimators x controllers, each through a plain Gymnasium "
                    "loop; prints a markdown table (RMSE, max error, lag, jerk, recovery after "
                    "occlusion, mean eta), saves it and Fig. 4-style plots in --out. --paper "
                    "runs the paper's experiments 1-4 against its statements.",
    )
    evaluate.add_argument("--scenario", nargs="+", default=None, choices=names,
                          help=f"one or more scenarios (default: {DEFAULTS['scenario'][0]}; "
                               "DON follows 1 to 3 links, the other estimators one); not with "
                               "--paper or --photos")
    from imimic_gym.suite import CONTROLLERS

    evaluate.add_argument("--estimator", nargs="+", default=None,
                          choices=estimator_names(),
                          help=f"default: {DEFAULTS['estimator'][0]}; oracle (the true angles) "
                               "only with --controller; not with --paper")
    add_checkpoint(evaluate)
    evaluate.add_argument("--modality", default=None, choices=("rgb", "depth"),
                          help="estimators alone: the colour video, or the depth video as grey "
                               f"frames (default: {DEFAULTS['modality']})")
    evaluate.add_argument("--json", default=None, help="also write the results to this file")
    evaluate.add_argument("--photos", default=None, metavar="ANNOTATIONS",
                          help="score on annotated photos instead: a COCO-keypoints file "
                               "(persons or arms); with --images; estimators that read a "
                               "frame alone (pose, cnn): PCP@0.5 of upper and lower arm and "
                               "the elbow-angle error")
    evaluate.add_argument("--images", default=None, metavar="DIR",
                          help="the folder of --photos' images")
    evaluate.add_argument("--controller", nargs="+", default=None, choices=tuple(CONTROLLERS),
                          help="run the tracking suite with these controllers: oracle (true "
                               "angles, the upper bound), position (the paper's servo), "
                               "velocity, torque (each keeps the start pose until the "
                               "estimator's first reading), learned "
                               "(the shipped policy: the planar arm's, or on spatial "
                               "scenarios the SO-101's)")
    evaluate.add_argument("--paper", action="store_true",
                          help="the paper's experiments 1-4 (DON + position and learned "
                               "controllers) as one table against the paper's statements")
    evaluate.add_argument("--num-envs", type=at_least(1), default=1,
                          help="clips stepped at once through gym.make_vec, one process each "
                               "(default: %(default)s)")
    add_clip_seeds(evaluate)
    evaluate.add_argument("--out", default=None,
                          help="suite only (--controller or --paper): folder for eval.md and "
                               f"plots/ (default: {DEFAULTS['out']})")
    add_backend(evaluate, "(scenario, estimator, controller, seed) cell; the same numbers "
                          "either way")
    evaluate.add_argument("--results", default=None, metavar="FILE.jsonl",
                          help="run cell by cell and append each finished cell's per-seed "
                               "metrics to this JSON-lines journal as it finishes, so an "
                               "interrupted sweep can --resume")
    evaluate.add_argument("--resume", action="store_true",
                          help="with --results: take the cells already in the journal and "
                               "run only the missing or failed ones")
    evaluate.set_defaults(func=cmd_eval)
