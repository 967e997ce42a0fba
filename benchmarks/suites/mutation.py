"""Suite ``mutation``: how many planted bugs the tests catch in the modules whose numbers
users read (issue 40).

mutmut (the ``mutation`` extra) mutates one module at a time (an operator swapped, a
constant changed, an argument dropped) and runs, for each mutant, only the tests of that
module (``MODULES``) that call the mutated function; a mutant is killed when one of them
fails, timed out when they exceed mutmut's CPU-time limit (``TIMEOUT_MULTIPLIER``,
``TIMEOUT_CONSTANT``), survived when they all pass, and not covered when none of the
module's tests calls its function. Each module runs in a scratch copy of the package and
tests, so the worktree is never touched. The JSON lists every surviving mutant (file:line,
the change); ``EQUIVALENT`` names the ones no test could tell from the original, with why.

    nice -n 10 .venv/bin/python benchmarks/run.py mutation
    nice -n 10 .venv/bin/python benchmarks/run.py mutation --parts lift   # one module again
"""

from __future__ import annotations

import ast
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from suites.pool import table

from imimic_gym.bench import machine

ROOT = Path(__file__).resolve().parents[2]
RESULTS = Path(__file__).resolve().parents[1] / "results"
# Each module (a part of the suite) and the test files that exercise it: the only tests
# its mutants run. A module that moves is a one-line change here.
MODULES: dict[str, tuple[str, tuple[str, ...]]] = {
    "metrics": ("imimic_gym/metrics.py", ("tests/test_metrics.py",)),
    "motion": ("imimic_gym/estimators/motion.py", ("tests/estimators/test_motion.py",)),
    "paper": ("imimic_gym/paper.py", ("tests/test_paper.py",)),
    "rollout": ("imimic_gym/rollout.py", ("tests/test_rollout.py",)),
    "kinematics": ("imimic_gym/kinematics.py", ("tests/test_kinematics.py",)),
    "directions": ("imimic_gym/retarget/directions.py", ("tests/retarget/test_directions.py",)),
    "mapping": ("imimic_gym/retarget/mapping.py", ("tests/retarget/test_mapping.py",)),
    "lift": ("imimic_gym/spatial/lift.py", ("tests/spatial/test_lift.py",
                                            "tests/spatial/test_lift_parts.py")),
    "share_filter": ("imimic_gym/spatial/share_filter.py", ("tests/spatial/test_share_filter.py",
                                                            "tests/spatial/test_lift.py")),
    "arm_pose": ("imimic_gym/spatial/arm_pose.py", ("tests/spatial/test_arm_pose.py",)),
}
PARTS = tuple(MODULES)
# Mutants no test could tell from the original (mutmut's name: why). They stay out of
# "killed"; the report gives the share with and without them.
_MAPPING = "imimic_gym.retarget.mapping.xǁPersonToRobotǁ"
_ARM_POSE = "imimic_gym.spatial.arm_pose.xǁArmPoseǁ"
_METRICS = "imimic_gym.metrics.x_"
_ROLLOUT = "imimic_gym.rollout."
_RESHAPE = "numpy's reshape infers a dimension given as any negative number, -2 as -1"
_ONLY_SHIFT_0 = ("with max_lag 0 the loop tries shift 0 alone and returns it: the early "
                 "return gives the same 0")
_SHIFT_0_SLICES = "at shift 0 both branches slice the whole signals"
_PROMOTED = ("this input only ever meets the other, still float64, in arithmetic, which "
             "promotes it to float64 first: the same numbers")
_REAL_MATMUL = ("the matrix (the mapping's, the arm frame's) is float64, so numpy's matmul "
                "promotes any real input to float64 first: the same numbers")
EQUIVALENT: dict[str, str] = {
    f"{_MAPPING}__post_init____mutmut_18": "a determinant of exactly 0 is no rotation: the "
                                           "orthonormality check before it refuses it",
    f"{_MAPPING}to_arm__mutmut_2": _REAL_MATMUL,
    f"{_MAPPING}to_arm__mutmut_4": _REAL_MATMUL,
    f"{_MAPPING}to_robot__mutmut_2": _REAL_MATMUL,
    f"{_MAPPING}to_robot__mutmut_4": _REAL_MATMUL,
    f"{_ARM_POSE}in_arm_frame__mutmut_2": _REAL_MATMUL,
    f"{_ARM_POSE}in_arm_frame__mutmut_4": _REAL_MATMUL,
    f"{_ARM_POSE}within_elbow_range__mutmut_1": "at exactly the range's end the flexion is "
                                                "set to the value it reads already",
    f"{_METRICS}bootstrap_interval__mutmut_17": "Generator.integers(n) draws from [0, n) as "
                                                "integers(0, n) does, the same stream",
    f"{_METRICS}lag_frames__mutmut_12": _RESHAPE,
    f"{_METRICS}lag_frames__mutmut_23": _RESHAPE,
    f"{_METRICS}jerk_rms__mutmut_11": _RESHAPE,
    f"{_METRICS}recovery_time_s__mutmut_29": _RESHAPE,
    f"{_METRICS}lag_frames__mutmut_28": "np.isfinite(...).all() is already bool",
    f"{_METRICS}lag_frames__mutmut_30": "np.isfinite(...).all() is already bool",
    f"{_METRICS}lag_frames__mutmut_59": _ONLY_SHIFT_0,
    f"{_METRICS}lag_frames__mutmut_60": _ONLY_SHIFT_0,
    f"{_METRICS}lag_frames__mutmut_76": _SHIFT_0_SLICES,
    f"{_METRICS}lag_frames__mutmut_77": _SHIFT_0_SLICES,
    f"{_METRICS}direction_error_deg__mutmut_3": _PROMOTED,
    f"{_METRICS}direction_error_deg__mutmut_5": _PROMOTED,
    f"{_METRICS}direction_error_deg__mutmut_7": _PROMOTED,
    f"{_METRICS}direction_error_deg__mutmut_9": _PROMOTED,
    f"{_METRICS}pcp__mutmut_4": _PROMOTED,
    f"{_METRICS}pcp__mutmut_6": _PROMOTED,
    f"{_ROLLOUT}xǁTrajectoryLogǁon_step__mutmut_7": "typing.cast does nothing at run time",
    f"{_ROLLOUT}xǁTrajectoryǁmetrics__mutmut_12": "with fewer than two frames no metric reads "
                                                  "the frame rate (jerk needs 4, recovery 2)",
}
TARGET = 0.8  # the bar: at least 80% of each module's mutants killed
# mutmut's per-mutant limit, CPU seconds: (the covering tests' time + constant) x multiplier x 2.
TIMEOUT_MULTIPLIER = 5.0
TIMEOUT_CONSTANT = 2.0
WORKERS = 2  # mutants tested at once (the machine has 2 cores)
STATUS = {"killed": "killed", "timeout": "timeouts", "survived": "survived",
          "no tests": "not_covered"}
MUTMUT_VERSION = "3.8.1"


def run(args: Any) -> dict[str, Any]:
    names = args.parts or PARTS
    if args.quick:
        names = names[:1] if args.parts else ("kinematics",)
    previous = RESULTS / "mutation.json"
    modules = (json.loads(previous.read_text())["modules"]
               if args.parts and previous.exists() else {})
    start = time.monotonic()
    for name in names:
        print(f"mutation: {name}", flush=True)
        modules[name] = mutate(name)
    return {"machine": machine(), "quick": bool(args.quick), "mutmut": MUTMUT_VERSION,
            "workers": WORKERS, "timeout_multiplier": TIMEOUT_MULTIPLIER,
            "timeout_constant": TIMEOUT_CONSTANT, "target": TARGET,
            "wall_s_this_run": round(time.monotonic() - start, 1),
            "parts_this_run": list(names),
            "modules": {name: modules[name] for name in PARTS if name in modules}}


def mutate(name: str) -> dict[str, Any]:
    """Run mutmut over module ``name`` with its tests, in a scratch copy; its counts,
    share killed and surviving mutants."""
    module, tests = MODULES[name]
    mutmut = Path(sys.executable).parent / "mutmut"
    with tempfile.TemporaryDirectory(prefix=f"mutation-{name}-") as scratch:
        work = Path(scratch)
        ignore = shutil.ignore_patterns("__pycache__", "*.pyc")
        shutil.copytree(ROOT / "imimic_gym", work / "imimic_gym", ignore=ignore)
        shutil.copytree(ROOT / "tests", work / "tests", ignore=ignore)
        (work / "pyproject.toml").write_text(config(module, tests))
        env = {**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")}
        start = time.monotonic()
        done = subprocess.run([str(mutmut), "run", "--max-children", str(WORKERS)], cwd=work,
                              env=env, capture_output=True, text=True)
        wall = time.monotonic() - start
        if done.returncode != 0:
            raise RuntimeError(f"mutmut on {module} exited {done.returncode}:\n"
                               f"{done.stdout[-3000:]}\n{done.stderr[-3000:]}")
        meta = json.loads((work / "mutants" / (module + ".meta")).read_text())
        statuses = {key: status(code) for key, code in meta["exit_code_by_key"].items()}
        left = sorted((k for k, s in statuses.items() if s in ("survived", "not_covered")),
                      key=mutant_order)
        diffs = mutant_diffs(work, mutmut, left)
    source = (ROOT / module).read_text()
    counts = {key: sum(s == key for s in statuses.values())
              for key in ("killed", "timeouts", "survived", "not_covered", "other")}
    total = len(statuses)
    caught = counts["killed"] + counts["timeouts"]
    equivalent = [k for k in left if k in EQUIVALENT]
    return {"module": module, "tests": list(tests), "mutants": total, **counts,
            "equivalent": len(equivalent),
            "killed_share": caught / total if total else None,
            "killed_share_without_equivalent":
                caught / (total - len(equivalent)) if total > len(equivalent) else None,
            "wall_s": round(wall, 1),
            "surviving": [{"mutant": key, "status": statuses[key],
                           **locate(source, module, key, diffs[key]),
                           **({"equivalent": EQUIVALENT[key]} if key in EQUIVALENT else {})}
                          for key in left]}


def config(module: str, tests: tuple[str, ...]) -> str:
    """The scratch copy's pyproject.toml: the project's (its pytest settings), and mutmut
    told to mutate ``module`` alone and to run ``tests`` alone."""
    lines = ["", "[tool.mutmut]", 'source_paths = ["imimic_gym"]',
             f"only_mutate = {json.dumps([module])}",
             f"pytest_add_cli_args_test_selection = {json.dumps(list(tests))}",
             'pytest_add_cli_args = ["-p", "no:cacheprovider", "-q"]',
             f"timeout_multiplier = {TIMEOUT_MULTIPLIER}",
             f"timeout_constant = {TIMEOUT_CONSTANT}",
             "use_git_change_detection = false"]
    return (ROOT / "pyproject.toml").read_text() + "\n".join(lines) + "\n"


def status(code: int | None) -> str:
    from mutmut.stats import status_by_exit_code

    return STATUS.get(status_by_exit_code[code], "other")


def mutant_order(key: str) -> tuple[str, int]:
    function, _, number = key.rpartition("__mutmut_")
    return function, int(number)


def mutant_diffs(work: Path, mutmut: Path, keys: list[str]) -> dict[str, str]:
    """mutmut's diff of each mutant in ``keys`` against the original function."""
    script = ("import json, sys\n"
              "from mutmut.mutation.diff_apply import get_diff_for_mutant\n"
              "keys = json.loads(sys.stdin.read())\n"
              "print(json.dumps({k: get_diff_for_mutant(k) for k in keys}))\n")
    python = mutmut.parent / "python"
    done = subprocess.run([str(python), "-c", script], cwd=work, input=json.dumps(keys),
                          capture_output=True, text=True, check=True)
    return json.loads(done.stdout.strip().splitlines()[-1])


def locate(source: str, module: str, key: str, diff: str) -> dict[str, Any]:
    """Where mutant ``key`` is in ``source`` (file:line) and its change, "old -> new"."""
    removed = [line[1:].strip() for line in diff.splitlines()
               if line.startswith("-") and not line.startswith("---")]
    added = [line[1:].strip() for line in diff.splitlines()
             if line.startswith("+") and not line.startswith("+++")]
    first, last = function_span(source, key)
    lines = source.splitlines()
    line = next((n for n in range(first, last + 1)
                 if removed and lines[n - 1].strip() == removed[0]), first)
    return {"where": f"{module}:{line}",
            "change": f"{' '.join(removed)} -> {' '.join(added)}"}


def function_span(source: str, key: str) -> tuple[int, int]:
    """The first and last line of the function mutant ``key`` mutates."""
    from mutmut.utils.format_utils import orig_function_and_class_names_from_key

    function, cls = orig_function_and_class_names_from_key(key)
    scope: list[ast.stmt] = ast.parse(source).body
    if cls is not None:
        scope = next(node.body for node in scope
                     if isinstance(node, ast.ClassDef) and node.name == cls)
    node = next(node for node in scope
                if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef)
                and node.name == function)
    return node.lineno, node.end_lineno or node.lineno


def share(value: float | None) -> str:
    return "-" if value is None else f"{100 * value:.0f}%"


def render(data: dict[str, Any]) -> str:
    m = data["machine"]
    modules = data["modules"]
    quick = "**A quick run (`--quick`): one module; not the reported figures.**\n\n" \
        if data.get("quick") else ""
    rows = [[f"`{r['module']}`", str(r["mutants"]), str(r["killed"]), str(r["timeouts"]),
             str(r["survived"]), str(r["not_covered"]), str(r["equivalent"]),
             share(r["killed_share"]), share(r["killed_share_without_equivalent"]),
             "met" if (r["killed_share"] or 0) >= data["target"] else "**missed**",
             f"{r['wall_s']:.0f}"]
            for r in modules.values()]
    missed = [r for r in modules.values() if (r["killed_share"] or 0) < data["target"]]
    total = sum(r["wall_s"] for r in modules.values())
    missed_text = ("Every module meets the bar." if not missed else
                   "Missed: " + "; ".join(f"`{r['module']}` ({share(r['killed_share'])})"
                                          for r in missed) + ".")
    return f"""## Mutation testing: the tests against planted bugs (suite `mutation`)

Command: `nice -n 10 .venv/bin/python benchmarks/run.py mutation` (mutmut
{data["mutmut"]}, the `mutation` extra; JSON: `benchmarks/results/mutation.json`, which
lists every surviving mutant with its file:line and change; this section is rendered from
it). Machine: {m["cpu"]}, {m["cores"]} cores, Python {m["python"]}, shared with other work;
{data["workers"]} mutants at a time. Each module's mutants run only that module's tests
(`MODULES` in `benchmarks/suites/mutation.py`), and of those only the ones that call the
mutated function; a mutant that exceeds (covering tests' time + {data["timeout_constant"]:g}
s) x {data["timeout_multiplier"]:g} x 2 of CPU time counts as a timeout. "Killed" below is
killed or timed out, over all mutants; "not covered": no test of the module calls the
mutated function. Survivors no test could tell from the original ("equivalent", counted
among the survivors; each with its reason in the JSON) count as not killed, and the last
share leaves them out. Bar: {share(data["target"])} killed per module.

{quick}{table(["module", "mutants", "killed", "timeouts", "survived", "not covered",
               "equivalent", "killed", "killed, equivalent left out", "80% bar",
               "time (s)"], rows)}

{missed_text} Time: each module's latest run, wall clock on the shared machine; a run of
every module takes their sum, {total / 60:.0f} minutes.
"""
