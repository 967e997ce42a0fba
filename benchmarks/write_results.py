"""Write benchmarks/RESULTS.md from the measurements in benchmarks/results/*.json.

Run after `bash benchmarks/run_all.sh`; every figure in RESULTS.md then comes from those
files, with the command that produced it. Usage: .venv/bin/python benchmarks/write_results.py
"""

from __future__ import annotations

import json
from pathlib import Path
from statistics import median

from results_don_links import don_links_section
from results_don_pivot import render as render_don_pivot

HERE = Path(__file__).parent
RESULTS = HERE / "results"
DECISIONS = HERE.parent / "docs" / "decisions"


def load(name: str):
    return json.loads((RESULTS / f"{name}.json").read_text())


def table(header: list[str], rows: list[list[str]]) -> str:
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(row) + " |" for row in rows]
    return "\n".join(lines)


def main() -> None:
    evaluation, depth = load("eval"), load("eval_depth")
    m = json.loads((RESULTS / "speed.json").read_text())["machine"] if (
        RESULTS / "speed.json").exists() else load("accuracy")["machine"]
    mean = {(r["scenario"], r["estimator"]): r for r in evaluation}

    def ev(scenario: str, estimator: str, key: str = "rmse_deg_settled") -> float:
        return mean[(scenario, estimator)]["mean"][key]

    def narrow_eta() -> str:
        gaps = [ev(a, "don", "mean_trust") - ev(b, "don", "mean_trust")
                for a, b in (("exp3-forearm-none", "exp3-forearm-low"),
                             ("exp3-forearm-low", "exp3-forearm-high"))]
        return (f" (a narrow margin: {min(gaps):.3f} at the smaller step)"
                if 0 < min(gaps) < 0.05 else "")

    def per_clip(scenario: str, estimator: str) -> str:
        rows = mean[(scenario, estimator)]["rows"]
        return ", ".join(f"{r['rmse_deg_settled']:.1f}" for r in rows)

    def verdict(ok: bool) -> str:
        return "**met**" if ok else "**not met**"

    def beats_both(estimator: str) -> str:
        """The scenarios where ``estimator`` has the lowest settled RMSE of the three."""
        won = [s for s in dict.fromkeys(r["scenario"] for r in evaluation)
               if all(ev(s, estimator) < ev(s, other)
                      for other in ("don", "mog2", "camshift") if other != estimator)]
        return ", ".join(f"`{s}`" for s in won) or "no scenario"

    def depth_gap(row: dict) -> float:
        """Depth's settled RMSE less colour's, on the same clips (deg)."""
        return row["mean"]["rmse_deg_settled"] - ev(row["scenario"], "don")

    def named(rows: list[dict]) -> str:
        return ", ".join(f"`{r['scenario']}`" for r in rows) or "no scenario"

    def within_a_degree(rows: list[dict]) -> str:
        return named([r for r in rows if abs(depth_gap(r)) <= 1])

    def depth_better(rows: list[dict]) -> str:
        return named([r for r in rows if depth_gap(r) < -1])

    def depth_worse(rows: list[dict]) -> str:
        return named([r for r in rows if depth_gap(r) > 1])

    episodes, first_seed = evaluation[0]["episodes"], evaluation[0]["first_seed"]

    out = [f"""# Measured results

Every figure here comes from a script in `benchmarks/`: `bash benchmarks/run_all.sh` (or
`make bench`) reruns them into `benchmarks/results/*.json`, and
`.venv/bin/python benchmarks/write_results.py` writes this file from those.

Machine: {m['cpu']}, {m['cores']} cores, no GPU, Python {m['python']}, MuJoCo {m['mujoco']},
Gymnasium {m['gymnasium']}, rendering with `MUJOCO_GL={m['MUJOCO_GL']}` (Mesa llvmpipe,
`LP_NUM_THREADS=1`). The machine is shared: absolute times move by tens of per cent from
run to run, which is why speed is reported against a reference measured in the same run
wherever there is one.

**The headline figures** are the first two sections below: every estimator, and every
controller with DON, on the test pool (30 fresh clips a scenario, seeds 40000-40029,
which no choice has touched; `docs/decisions/evaluation-protocol.md`). The sections after
them keep the record of how the code got here; their "held-out" figures come from seeds
1000-1009, evaluated after many rounds of choices and now
**retired**: where they differ from the test pool, the test pool is right. The one-off
experiments behind a choice are in its decision record, with their figures and the
command that reruns them: {decision_records()}.
{suite_section("speed")}{suite_section("accuracy")}{suite_section("tracking")}{suite_section("paper")}{suite_section("scaleout")}
## DON and the baselines on retired seeds (issue 3)

### Accuracy on held-out clips

Command: `.venv/bin/imimic eval --scenario exp2-servo default exp3-forearm-none
exp3-forearm-low exp3-forearm-high exp1-noisy-fast --estimator don don-paper mog2
camshift --episodes {episodes} --json benchmarks/results/eval.json`

Estimator-only (no robot), clip seeds {first_seed}-{first_seed + episodes - 1} (tests and
development use seeds below 1000), 150 frames each, means over the clips. "Settled" leaves
out the first 0.5 s: a frame-differencing estimator sees nothing before the arm moves.
Lag: cross-correlation peak, in frames.

{table(["scenario", "estimator", "RMSE (deg)", "settled RMSE (deg)", "lag", "mean eta"],
       [[f"`{r['scenario']}`", r["estimator"], f"{r['mean']['rmse_deg']:.2f}",
         f"{r['mean']['rmse_deg_settled']:.2f}", f"{r['mean']['lag_frames']:.1f}",
         f"{r['mean']['mean_trust']:.2f}"] for r in evaluation])}

"don" is the default DON, with our appearance layer; "don-paper" is DON with the paper's
layers alone (`DON(appearance=False)`), on the same clips.

Occluded frames (over 10% of the moving links hidden), DON with the prediction layer off
and on (trust threshold 0.3):

{table(["scenario", "estimator", "prediction off (deg)", "prediction on (deg)"],
       [[f"`{r['scenario']}`", r["estimator"], f"{r['mean']['rmse_occluded_deg_prediction_off']:.1f}",
         f"{r['mean']['rmse_occluded_deg_prediction_on']:.1f}"]
        for r in evaluation if "rmse_occluded_deg_prediction_on" in r["mean"]])}

DON on the depth video of the same clips (the paper ran DON on both and found the same
result). Command: `.venv/bin/imimic eval --scenario exp2-servo default exp3-forearm-none
exp3-forearm-low exp3-forearm-high exp1-noisy-fast --estimator don --episodes {episodes}
--modality depth --json benchmarks/results/eval_depth.json`

{table(["scenario", "RGB settled RMSE (deg)", "depth settled RMSE (deg)", "depth lag", "depth mean eta"],
       [[f"`{r['scenario']}`", f"{ev(r['scenario'], 'don'):.2f}", f"{r['mean']['rmse_deg_settled']:.2f}",
         f"{r['mean']['lag_frames']:.1f}", f"{r['mean']['mean_trust']:.2f}"] for r in depth])}

Depth is within a degree of colour on {within_a_degree(depth)}; better by more on
{depth_better(depth)}; worse by more on {depth_worse(depth)}. A depth frame shows no
background texture and no coloured posters, only what stands out in distance; but the
occluder stands out in depth too, and the thin forearm against the wall barely does.

The clips differ a lot from one another in the cluttered scenarios: per clip, DON's
settled RMSE on `exp3-forearm-low` is {per_clip('exp3-forearm-low', 'don')} degrees. Means over three clips, as this
file reported before, were not enough to rank the estimators there.

Against issue 3's acceptance:
- `exp2-servo` at most 3 degrees and at most 2 frames of lag: {verdict(ev('exp2-servo', 'don') <= 3 and abs(ev('exp2-servo', 'don', 'lag_frames')) <= 2)} after the
  0.5 s warm-up ({ev('exp2-servo', 'don'):.2f} degrees, lag {ev('exp2-servo', 'don', 'lag_frames'):.1f}); over all frames
  {ev('exp2-servo', 'don', 'rmse_deg'):.2f}: the rest is the first half second, before the servo has moved.
- `exp3-forearm-none` at most 4 degrees: {verdict(ev('exp3-forearm-none', 'don') <= 4)} ({ev('exp3-forearm-none', 'don'):.1f}; per clip
  {per_clip('exp3-forearm-none', 'don')}).
- `exp3-forearm-high` at most 10 degrees: {verdict(ev('exp3-forearm-high', 'don') <= 10)} ({ev('exp3-forearm-high', 'don'):.1f}; per clip
  {per_clip('exp3-forearm-high', 'don')}).
{render_don_pivot(load, table)}
{fresh_clips(load("eval_fresh"), ev)}
- Trust factor strictly decreasing from none to low to high occlusion:
  {verdict(ev('exp3-forearm-none', 'don', 'mean_trust') > ev('exp3-forearm-low', 'don', 'mean_trust') > ev('exp3-forearm-high', 'don', 'mean_trust'))}; mean eta {ev('exp3-forearm-none', 'don', 'mean_trust'):.2f}, {ev('exp3-forearm-low', 'don', 'mean_trust'):.2f}, {ev('exp3-forearm-high', 'don', 'mean_trust'):.2f}{narrow_eta()}. eta is the paper's formula with M_p
  the link's visible length (how far from the pivot its moving regions reach; a link
  missing for two frames or more after turning fast counts as 0 until it is seen again,
  so a long occlusion keeps eta at 0 rather than drifting back to 1 once the last
  measurement leaves the window; before DON's first reading it is 0 too, as its angle is
  then a placeholder, the middle of the joint range). On a hand-built bar it reads what it should
  (`tests/estimators/test_don.py`, the bar smoothed by the 7x7 Gaussian: above 0.95 in
  the clear, within a few hundredths of the fraction left visible when the outer 20, 50
  or 70% is hidden, 0 with most of it hidden; with DON's default, no Gaussian, the
  hard-edged bar's readings scatter by about 3%, 0.94-0.99 in the clear). On the rendered clips its mean on occluded
  frames against clear ones is {ev('exp3-forearm-low', 'don', 'mean_trust_occluded'):.2f} against {ev('exp3-forearm-low', 'don', 'mean_trust_clear'):.2f} in `exp3-forearm-low` and
  {ev('exp3-forearm-high', 'don', 'mean_trust_occluded'):.2f} against {ev('exp3-forearm-high', 'don', 'mean_trust_clear'):.2f} in `exp3-forearm-high`. Only 15% of `exp3-forearm-low`'s frames and 30%
  of `exp3-forearm-high`'s are occluded; on the rest eta also drops wherever the
  tracker loses the forearm among the occluder's moving edges, as much in one scenario
  as in the other. With the elbow given (development clips, `benchmarks/don_dev_seeds.py
  --pivot-given`) eta does fall from none to low to high.
- Prediction layer lowering RMSE on occluded frames: {verdict(all(r['mean']['rmse_occluded_deg_prediction_on'] < r['mean']['rmse_occluded_deg_prediction_off'] for r in evaluation if r['estimator'] == 'don' and 'rmse_occluded_deg_prediction_on' in r['mean']))} for the default DON (table above; the
  issue asks it of `exp3-forearm-low`, where it is {verdict(ev('exp3-forearm-low', 'don', 'rmse_occluded_deg_prediction_on') < ev('exp3-forearm-low', 'don', 'rmse_occluded_deg_prediction_off'))}: {ev('exp3-forearm-low', 'don', 'rmse_occluded_deg_prediction_on'):.2f} on against {ev('exp3-forearm-low', 'don', 'rmse_occluded_deg_prediction_off'):.2f} off{", within a tenth of a degree: a tie on ten clips" if abs(ev('exp3-forearm-low', 'don', 'rmse_occluded_deg_prediction_on') - ev('exp3-forearm-low', 'don', 'rmse_occluded_deg_prediction_off')) < 0.1 else ""}); it is off by default.
- DON beats MOG2 and CamShift on `exp3-forearm-low`: {verdict(ev('exp3-forearm-low', 'don') < min(ev('exp3-forearm-low', 'mog2'), ev('exp3-forearm-low', 'camshift')))} ({ev('exp3-forearm-low', 'don'):.1f} against
  {ev('exp3-forearm-low', 'mog2'):.1f} and {ev('exp3-forearm-low', 'camshift'):.1f}). DON beats both on {beats_both('don')}; CamShift
  beats both on {beats_both('camshift')}. CamShift follows a colour, which works where the arm's skin stands
  out and fails wherever the arm has no distinct hue (the paper link of `exp2-servo`).
- 2-link chain and `exp4-hand`: DON for several links, in its own section below.
"""]
    out.append(real_footage_section())
    out.append(suite_section("cnn"))
    out.append(suite_section("fresh_clone"))
    out.append(don_links_section())
    (HERE / "RESULTS.md").write_text("".join(out))


def fresh_clips(fresh: list[dict], held_out) -> str:
    """The person scenarios on 30 fresh clips: how far ten held-out clips can be trusted."""
    first, episodes = fresh[0]["first_seed"], fresh[0]["episodes"]
    cells = ", ".join(
        f"`{r['scenario']}` {r['mean']['rmse_deg_settled']:.1f} (held-out "
        f"{held_out(r['scenario'], 'don'):.1f})" for r in fresh)
    high = next(r for r in fresh if r["scenario"] == "exp3-forearm-high")
    clips = [row["rmse_deg_settled"] for row in high["rows"]]
    return f"""- Ten clips a scenario are few where one lost forearm costs a clip tens of degrees. On
  {episodes} fresh clips (seeds {first}-{first + episodes - 1}, never used to choose a rule; command:
  `.venv/bin/imimic eval
  --scenario exp3-forearm-none exp3-forearm-low exp3-forearm-high --estimator don
  --episodes {episodes} --first-seed {first} --json benchmarks/results/eval_fresh.json`) DON's
  settled RMSE is {cells} degrees. On `exp3-forearm-high` the median clip is {median(clips):.1f}
  and {sum(c > 20 for c in clips)} of the {episodes} are over 20 degrees: the larger sample puts it
  {"over" if high["mean"]["rmse_deg_settled"] > 10 else "within"} the acceptance's 10 too."""


def suite_section(name: str) -> str:
    """A suite's report, rendered by `benchmarks/run.py NAME` from its JSON alone
    (results/NAME.md from results/NAME.json); nothing before the suite has run."""
    path = RESULTS / f"{name}.md"
    return "\n" + path.read_text() if path.exists() else ""


def decision_records() -> str:
    """The records in docs/decisions/, as links from this file."""
    return ", ".join(f"[`{path.stem}`](../docs/decisions/{path.name})"
                     for path in sorted(DECISIONS.glob("*.md")))


def real_footage_section() -> str:
    """Real people: the `real` suite's report."""
    return suite_section("real")

if __name__ == "__main__":
    main()
