"""Write benchmarks/RESULTS.md: an introduction, then each suite's section as
`benchmarks/run.py` rendered it from the suite's JSON (results/<suite>.md), in a fixed
order. Every figure comes from a suite; this file types and computes none.

    .venv/bin/python benchmarks/write_results.py    (run.py calls it after a run)
"""

from __future__ import annotations

import json
from pathlib import Path

from run import SUITES

HERE = Path(__file__).parent
RESULTS = HERE / "results"
DECISIONS = HERE.parent / "docs" / "decisions"
# The order of the sections: every suite of `run.py`, the headline figures first.
ORDER = ("accuracy", "tracking", "paper", "speed", "cnn", "real", "spatial", "scaleout",
         "fresh_clone", "mutation")
assert sorted(ORDER) == sorted(SUITES), "write_results.ORDER must list run.SUITES"


def suite_section(name: str) -> str:
    """A suite's report, rendered by `benchmarks/run.py NAME` from its JSON alone
    (results/NAME.md from results/NAME.json); nothing before the suite has run."""
    path = RESULTS / f"{name}.md"
    return "\n" + path.read_text() if path.exists() else ""


def decision_records() -> str:
    """The records in docs/decisions/, as links from this file."""
    return ", ".join(f"[`{path.stem}`](../docs/decisions/{path.name})"
                     for path in sorted(DECISIONS.glob("*.md")))


def machine() -> str:
    """The machine, as the first suite in ORDER that has run recorded it."""
    for name in ORDER:
        path = RESULTS / f"{name}.json"
        if path.exists():
            m = json.loads(path.read_text())["machine"]
            return (f"Machine: {m['cpu']}, {m['cores']} cores, no GPU, Python {m['python']}, "
                    f"MuJoCo {m['mujoco']}, Gymnasium {m['gymnasium']}, rendering with "
                    f"`MUJOCO_GL={m['MUJOCO_GL']}` (Mesa llvmpipe, `LP_NUM_THREADS=1`), as "
                    f"the `{name}` suite recorded it; each section names its own.")
    return "No suite has run yet."


def introduction() -> str:
    return f"""# Measured results

Every figure here comes from a suite of the benchmark runner: `.venv/bin/python
benchmarks/run.py SUITE` (or `all`; `make bench` runs `all --backend ray`) writes
`benchmarks/results/SUITE.json`, renders `SUITE.md` from it, and writes this file from
those. A suite not yet run has no section. Missing sections now: {missing()}.

{machine()} The machine is shared: absolute times move by tens of per cent from run to
run, which is why every speed is a ratio to a reference measured in the same run.

**The accuracy and tracking figures** come from the test pool (30 fresh clips a scenario,
seeds 40000-40029, which no choice has touched; `docs/decisions/evaluation-protocol.md`).
The figures of the rounds that chose the rules, on development seeds and on the retired
held-out seeds 1000-1009 and 2000-2029, are in the decision records, with the command
that reruns them: {decision_records()}.
"""


def missing() -> str:
    names = [f"`{name}`" for name in ORDER if not (RESULTS / f"{name}.md").exists()]
    return ", ".join(names) or "none"


def main() -> None:
    (HERE / "RESULTS.md").write_text(
        introduction() + "".join(suite_section(name) for name in ORDER))


if __name__ == "__main__":
    main()
