"""RESULTS.md section for issue 5 (controllers and the evaluation suite), rendered from
benchmarks/results/tracking_heldout.json, paper_heldout.json, paper_time.json and checkpoints/tracker.json.
Called by write_results.py."""

from __future__ import annotations

import json
from collections.abc import Callable

from results_learned import candidates, error_sources, fresh_seeds, retrain

from imimic_gym.checkpoints import SHIPPED_CHECKPOINTS
from imimic_gym.paper import paper_table

SCRIPTED = ("position", "velocity", "torque")


def _verdict(ok: bool) -> str:
    return "**met**" if ok else "**not met**"


def render(load: Callable[[str], object],
           table: Callable[[list[str], list[list[str]]], str]) -> str:
    tracking, paper, timing = load("tracking_heldout"), load("paper_heldout"), load("paper_time")
    meta = json.loads((SHIPPED_CHECKPOINTS / "tracker.json").read_text())
    rmse = {(r["scenario"], r["controller"]): r["mean"]["rmse_deg"] for r in tracking}
    seeds = tracking[0]["seeds"]

    def shown(value: float | None, digits: int) -> str:
        return "-" if value is None else f"{value:.{digits}f}"

    rows = [[f"`{r['scenario']}`", r["controller"], f"{r['mean']['rmse_deg']:.2f}",
             f"{r['mean']['max_error_deg']:.1f}", f"{r['mean']['lag_frames']:.1f}",
             shown(r["mean"]["jerk_deg_s3"], 0), shown(r["mean"]["recovery_s"], 2),
             shown(r["mean"]["mean_trust"], 2)] for r in tracking]
    checks = []
    for scenario in ("exp2-servo", "exp3-forearm-low"):
        learned = rmse[(scenario, "learned")]
        best = min(SCRIPTED, key=lambda c, s=scenario: rmse[(s, c)])
        cut = 1 - learned / rmse[(scenario, best)]
        change = f"{100 * cut:.1f}% lower" if cut >= 0 else f"{-100 * cut:.1f}% higher"
        checks.append(f"  - `{scenario}` (best scripted: {best}, "
                      f"{rmse[(scenario, best)]:.2f} deg): learned {learned:.2f} deg, "
                      f"{change}; 20% lower needed: {_verdict(cut >= 0.2)}.")
    fresh = {(r["scenario"], r["controller"]): r["mean"]["rmse_deg"]
             for r in load("tracking_fresh")}
    fresh_servo = ("behind velocity, so its margin here is within the spread between "
                   "sets of ten clips"
                   if fresh[("exp2-servo", "learned")] >= fresh[("exp2-servo", "velocity")]
                   else "ahead of velocity as well")
    sources = {r["controller"]: r["rmse_deg"] for r in load("servo_error_sources")["rows"]
               if r["estimator"] == "don"}
    servo = rmse[("exp2-servo", "position")]
    val = meta["val_metrics"]
    return f"""

## Tracking controllers and the evaluation suite (issue 5)

Command: `.venv/bin/imimic eval --scenario exp2-servo exp3-forearm-low --estimator don
--controller position velocity torque learned --episodes {len(seeds)} --num-envs 2 --out benchmarks/results/tracking_heldout --json
benchmarks/results/tracking_heldout.json`

DON's estimates drive every controller; held-out clip seeds {seeds[0]}-{seeds[-1]} (training
used seeds below 1000), full 150-frame clips, means over the seeds. Jerk is the robot's
RMS third derivative; recovery is the time from the end of an occlusion until every joint
is within 5 degrees again (a lower bound when it never gets there). Every controller
keeps the start pose until DON's first reading (before it, DON reports the middle of the
joint range with trust 0, while the robot starts at the arm's pose). `learned` is the
shipped policy (`imimic_gym/data/checkpoints/tracker.pt`): {meta['algorithm'].upper()}, a residual on the {meta['control']} controller, trained {meta['total_timesteps']} steps in {meta['train_seconds']:.0f} s with {meta['torch_threads']} torch thread on this machine (shared with other jobs), on scenarios {', '.join(meta['scenarios'])}, clip seeds {meta['train_seeds'][0]}-{meta['train_seeds'][-1]}, stable-baselines3 {meta['stable_baselines3']}; command: `.venv/bin/{meta.get('command', 'python training/train_tracker.py')}`{' (its output then copied to `imimic_gym/data/checkpoints/`)' if '--out' in meta.get('command', '') else ''}.

{table(["scenario", "controller", "RMSE (deg)", "max (deg)", "lag (frames)", "jerk (deg/s^3)",
        "recovery (s)", "mean eta"], rows)}

Against issue 5's acceptance:
- DON + position controller on `exp2-servo` at most 4 degrees: {_verdict(servo <= 4.0)}
  ({servo:.2f}). The same servo chasing DON's placeholder from the first frame (`chasing`
  in the error-sources table below: what the position controller did until it waited for
  DON's first reading) gets {sources['chasing']:.2f}.
- Learned controller at least 20% below the best scripted controller:
{chr(10).join(checks)}
- The shipped policy was chosen on validation clips (seeds below 1000) among the
  candidates listed below; its validation RMSE (deg) from its own training run (clip seeds
  {meta['val_seeds']}): {', '.join(f'{k} {v:.2f}' for k, v in val.items())}.
{fresh_seeds(load, table)}{error_sources(load, table)}{candidates(load, table, meta['command'])}{retrain(load, table, meta['command'])}
### The paper's experiments

Command: `.venv/bin/imimic eval --paper --json benchmarks/results/paper_heldout.json --out
benchmarks/results/paper_heldout` ({paper[0]['episodes']} held-out seeds each, retired).

{paper_table(paper)}

`imimic eval --paper` from an empty clip cache (a fresh clone renders every clip first;
the package install by `make setup` is not counted), command
`.venv/bin/python benchmarks/eval_paper_time.py --json benchmarks/results/paper_time.json`:
{timing['seconds']:.0f} s (limit 600 s): {_verdict(timing['seconds'] <= timing['limit_seconds'])}.

Reading the tables:
- On `exp2-servo` the learned policy ({rmse[("exp2-servo", "learned")]:.2f} deg against
  velocity's {rmse[("exp2-servo", "velocity")]:.2f}) sees {meta.get('rate_history_frames', 0)} past frames of
  DON's omega and the angle's recent changes as rates; on the fresh clips it is
  {fresh_servo}. A
  scripted difference feed-forward tracks to {sources['difference']:.2f} deg on the held-out clips
  (subsections above): the servo's bar is mostly DON's noisy omega, not anticipation.
- On `exp3-forearm-low` DON's estimate is the limit (its estimator-only RMSE is in the
  DON section above): every controller inherits its wrong stretches, and the policy
  ({rmse[("exp3-forearm-low", "learned")]:.2f} deg) follows fewer of them than
  velocity ({rmse[("exp3-forearm-low", "velocity")]:.2f}) (fresh clips:
  {fresh[("exp3-forearm-low", "learned")]:.2f} against
  {fresh[("exp3-forearm-low", "velocity")]:.2f}); which jumps it declines is not traced frame by frame yet.
- The policy's jerk is several times the scripted controllers': it moves the velocity
  command every frame (no smoothness term in its reward yet).
"""
