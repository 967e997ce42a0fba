"""The benchmark runner: one command per named suite, JSON out, a report rendered from
the JSON alone.

    .venv/bin/python benchmarks/run.py real            # run, write results/real.json + .md
    .venv/bin/python benchmarks/run.py real --render   # re-render results/real.md only
    .venv/bin/python benchmarks/run.py all --backend ray   # every suite, then RESULTS.md

Each suite is a module in ``benchmarks/suites/`` with ``run(args) -> dict`` (everything
it measured, the machine included) and ``render(data) -> str`` (Markdown, every figure
read from ``data``). After a run, ``benchmarks/write_results.py`` puts the rendered
sections into RESULTS.md, after an introduction.
"""

from __future__ import annotations

import argparse
import importlib
import json
import sys
from pathlib import Path

from imimic_gym.backends import BACKENDS

ROOT = Path(__file__).resolve().parent
RESULTS = ROOT / "results"
SUITES = {
    "speed": "env steps, clip rendering, DON against MOG2 (the paper's Table 1 and Fig. 3), "
             "LinkedDON and DON's compile time, each against a reference in the same run",
    "accuracy": "every video estimator on the test pool, per scenario and per joint",
    "tracking": "the controllers on the test pool, and the learned tracker's margin",
    "paper": "the paper's experiments 1-4 on the test pool against its statements",
    "scaleout": "Ray against one process on the same sweep and the same renders, and the "
                "cost of 10,000 clips on N nodes",
    "cnn": "the shipped CNN + refiner checkpoints on their test images, the CNN and DON "
           "on the same test-pool clips, and the CNN's time per frame against DON's",
    "fresh_clone": "what a fresh clone waits for, from an empty clip cache: imimic eval "
                   "--paper and the CNN's default training run, against their limits",
    "real": "real people: the pose model, pose-seeded DON and every estimator on real "
            "photos and videos (../shared/realdata), and on rendered clips",
    "spatial": "the arm in 3-D: pose3d, pose-world and pose3d on depth against the rendered "
               "3-D truth, and the SO-101 copying it",
    "mutation": "mutmut over the modules whose numbers users read, each with its own tests: "
                "the share of planted bugs the tests catch, and the ones they miss",
}


def load(name: str):
    """The suite module ``name``."""
    sys.path.insert(0, str(ROOT))
    try:
        return importlib.import_module(f"suites.{name}")
    finally:
        sys.path.pop(0)


def parts(name: str) -> tuple[str, ...]:
    """The parts of suite ``name`` that --parts may name (its module's ``PARTS``; a suite
    without them runs whole)."""
    return tuple(getattr(load(name), "PARTS", ()))


def check_parts(parser: argparse.ArgumentParser, args: argparse.Namespace) -> None:
    """Refuse, before any suite runs, --parts that are not parts of the one suite named."""
    if not args.parts:
        return
    if args.suite == "all":
        parser.error("--parts names parts of one suite, not of all")
    known = parts(args.suite)
    unknown = [part for part in args.parts if part not in known]
    if unknown:
        parser.error(f"suite {args.suite} has no part {', '.join(unknown)}; "
                     + (f"its parts: {', '.join(known)}" if known else "it runs whole"))


def main() -> None:
    parser = argparse.ArgumentParser(
        description="Run a named benchmark suite (or all), write results/<suite>.json and "
                    ".md, and RESULTS.md from them: " + "; ".join(
                        f"{name}: {text}" for name, text in SUITES.items()))
    parser.add_argument("suite", choices=[*sorted(SUITES), "all"])
    parser.add_argument("--render", action="store_true",
                        help="only render results/<suite>.md from results/<suite>.json")
    parser.add_argument("--quick", action="store_true",
                        help="a small run to check the suite works (figures not for RESULTS)")
    parser.add_argument("--parts", nargs="+", default=None, metavar="PART",
                        help="run only these parts of the suite and replace them in the "
                             "existing results/<suite>.json (e.g. speed again on a quiet "
                             "machine); default: all. Parts: " + "; ".join(
                                 f"{name}: {', '.join(parts(name)) or 'none (runs whole)'}"
                                 for name in SUITES))
    parser.add_argument("--backend", default="local", choices=BACKENDS,
                        help="suites that sweep clips (accuracy, tracking, paper, cnn): run the "
                             "cells here or as Ray tasks (default: %(default)s)")
    parser.add_argument("--address", default=None,
                        help="--backend ray: an existing cluster (default: a local Ray)")
    parser.add_argument("--resume", action="store_true",
                        help="suites that sweep clips: go on from results/<suite>.cells.jsonl "
                             "after an interruption")
    args = parser.parse_args()
    check_parts(parser, args)
    for name in SUITES if args.suite == "all" else [args.suite]:
        run_suite(name, args)
    if not args.quick:
        import write_results

        write_results.main()
        print(f"wrote {ROOT / 'RESULTS.md'}")


def run_suite(name: str, args: argparse.Namespace) -> None:
    suite = load(name)
    data_path, report_path = RESULTS / f"{name}.json", RESULTS / f"{name}.md"
    if args.render:
        data = json.loads(data_path.read_text())
    else:
        data = suite.run(args)
        if args.parts and data_path.exists():
            data = {**json.loads(data_path.read_text()), **data}
        if args.quick:
            data_path, report_path = (data_path.with_suffix(".quick.json"),
                                      report_path.with_suffix(".quick.md"))
        RESULTS.mkdir(exist_ok=True)
        data_path.write_text(json.dumps(data, indent=1) + "\n")
        print(f"wrote {data_path}")
    report_path.write_text(suite.render(data))
    print(f"wrote {report_path}")


if __name__ == "__main__":
    main()
