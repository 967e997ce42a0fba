"""RESULTS.md subsections for the learned tracker (issue 5): where the servo's error comes
from (benchmarks/results/servo_error_sources.json) and how the shipped policy was chosen
on validation clips (tracker_candidates.json). Called by results_tracking.render."""

from __future__ import annotations

from collections.abc import Callable


def error_sources(load: Callable[[str], object],
                  table: Callable[[list[str], list[list[str]]], str]) -> str:
    data = load("servo_error_sources")
    rows = {(r["estimator"], r["controller"]): r for r in data["rows"]}
    don = data["don"]
    seeds = data["seeds"]
    shown = [[r["estimator"], r["controller"], f"{r['rmse_deg']:.2f}", f"{r['lag_frames']:.1f}",
              f"{r['jerk_deg_s3']:.0f}"] for r in data["rows"]]
    floor = rows[("oracle", "velocity")]["rmse_deg"]
    velocity = rows[("don", "velocity")]["rmse_deg"]
    difference = rows[("don", "difference")]["rmse_deg"]
    chasing = rows[("don", "chasing")]["rmse_deg"]
    position = rows[("don", "position")]["rmse_deg"]
    return f"""

### Where the servo's error comes from

Command: `.venv/bin/python benchmarks/servo_error_sources.py --json
benchmarks/results/servo_error_sources.json` (`{data['scenario']}`, clip seeds
{seeds[0]}-{seeds[-1]}, means over the seeds; this diagnosis chose nothing).

{table(["estimator", "controller", "RMSE (deg)", "lag (frames)", "jerk (deg/s^3)"], shown)}

- The dynamics floor is small: fed the true angle, omega and alpha, the velocity
  controller tracks to {floor:.2f} deg. With DON it is {velocity:.2f} deg, so nearly all of it
  is the estimate.
- DON's angle on the frame it describes is off by {don['angle_rmse']:.2f} deg RMS (from the
  first reading on), but its omega by {don['omega_rmse']:.1f} deg/s RMS (against the
  truth's central difference), so its one-frame lead (angle + omega / fps) misses the
  next frame by {don['lead_omega_rmse']:.2f} deg. (Until this round DON's omega stayed 0
  until its pivot was agreed, on clip 100 from frame 4 to frame 24; its guesses before
  the pivot now feed the path estimator; this script's run before that change, at
  commit fe56b9a, measured the omega error at 26.9 deg/s.)
- `difference`, a diagnostic defined only in the script (velocity with DON's omega
  replaced by the last change of DON's angle times fps), tracks to {difference:.2f} deg,
  although that change, used as a one-frame lead on its own, misses the next frame by
  {don['lead_difference_rmse']:.2f} deg: the velocity servo averages it. So on this
  scenario issue 5's bar measures DON's omega more than the controllers' dynamics.
- `chasing`, another diagnostic defined only in the script: the position servo following
  DON's estimate from the first frame, its placeholder included (the middle of the joint
  range, reported with trust 0 until DON's first reading). It tracks to {chasing:.2f} deg
  against the position controller's {position:.2f}: the servo driven away from the arm's
  pose and back in the first frames. Waiting for the first reading is what the package's
  controllers do.
"""


def candidates(load: Callable[[str], object],
               table: Callable[[list[str], list[list[str]]], str], shipped: str) -> str:
    data = load("tracker_candidates")
    scenarios = list(dict.fromkeys(r["scenario"] for r in data["rows"]))
    by_name: dict[str, dict[str, dict]] = {}
    for row in data["rows"]:
        # Measured when waiting for DON's first reading was the "-hold" option.
        by_name.setdefault(row["candidate"].removesuffix("-hold"), {})[row["scenario"]] = row
    reference = by_name["velocity"]
    lines = []
    for name, cells in by_name.items():
        first = next(iter(cells.values()))
        rmse = [f"{cells[s]['rmse_deg']:.2f}" for s in scenarios]
        if "setup" not in first:
            lines.append([name, "", "", "", "", "", "", *rmse, "", ""])
            continue
        setup = first["setup"]
        worst = max(cells[s]["rmse_deg"] / reference[s]["rmse_deg"] for s in scenarios)
        wide = "" if first.get("net_arch", [64, 64]) == [64, 64] else (
            " (" + " x ".join(map(str, first["net_arch"])) + ")")
        lines.append([setup["control"] + wide, str(setup["features_version"]),
                      str(setup["rate_history"]), str(setup["reward_balance"]),
                      str(setup["gradient_steps"]), str(setup["total_timesteps"]),
                      f"{first['train_seconds']:.0f}", *rmse, f"{worst:.3f}",
                      "shipped" if first["command"] == shipped else ""])
    seeds = data["seeds"]
    return f"""

### How the shipped policy was chosen

Command: `.venv/bin/python benchmarks/tracker_candidates.py <candidate .pt files> --json
benchmarks/results/tracker_candidates.json`: each candidate trained by
`training/train_tracker.py` (SAC, 4 scenarios x clip seeds 0-47, history 6, 64 x 64
layers unless marked, the options shown; training seconds measured on this machine while
other jobs shared its 2 cores), run with DON on validation clip seeds
{seeds[0]}-{seeds[-1]} (never trained on, below the held-out 1000) next to the scripted
position and velocity controllers. Rule, fixed before the held-out run: ship the
candidate whose worse ratio to the velocity controller over the two scenarios is lowest
(issue 5 wants both at most 0.8); the first candidate is the policy shipped before this
round. No candidate reached 0.8 on both. Held-out and fresh seeds were run only for a
policy while it was shipped: the 64 x 64 run with features 2 and balance 0.75 was
shipped first (commit b98b3b9: held-out 1.26 and 25.70 deg, fresh 1.80 and 23.99 deg,
`exp2-servo` and `exp3-forearm-low`) and replaced by the 128 x 128 run (`--net-arch 128
128`, now the default) when that finished with a lower worse ratio on the validation
clips.

{table(["control", "features", "rate history", "reward balance", "gradient steps",
        "steps", "train (s)", *(f"`{s}` RMSE (deg)" for s in scenarios),
        "worse ratio", ""], lines)}
"""


def fresh_seeds(load: Callable[[str], object],
                table: Callable[[list[str], list[list[str]]], str]) -> str:
    data = load("tracking_fresh")
    seeds = data[0]["seeds"]
    rows = [[f"`{r['scenario']}`", r["controller"], f"{r['mean']['rmse_deg']:.2f}",
             f"{r['mean']['max_error_deg']:.1f}", f"{r['mean']['jerk_deg_s3']:.0f}"]
            for r in data]
    rmse = {(r["scenario"], r["controller"]): r["mean"]["rmse_deg"] for r in data}
    cuts = ", ".join(
        f"`{s}` {100 * (1 - rmse[(s, 'learned')] / rmse[(s, 'velocity')]):.0f}%"
        for s in dict.fromkeys(r["scenario"] for r in data))
    return f"""

### Fresh clips, measured once

Command: `.venv/bin/imimic eval --scenario exp2-servo exp3-forearm-low --estimator don
--controller position velocity learned --episodes 10 --first-seed {seeds[0]}
--num-envs 2 --json benchmarks/results/tracking_fresh.json`: clip seeds
{seeds[0]}-{seeds[-1]}, run once after the policy was shipped, to check that the
held-out figure above is not a property of seeds 1000-1009.

{table(["scenario", "controller", "RMSE (deg)", "max (deg)", "jerk (deg/s^3)"], rows)}

Learned below velocity by: {cuts} (20% needed on both).
"""


def _worse_ratios(data: dict) -> dict[str, float]:
    """Each candidate's worse ratio to the velocity controller over the scenarios of a
    `tracker_candidates.py` run, keyed by its file's stem (``s1`` for ``.../s1.pt``)."""
    velocity = {r["scenario"]: r["rmse_deg"] for r in data["rows"]
                if r["candidate"] == "velocity"}
    worst: dict[str, float] = {}
    for r in data["rows"]:
        if r["candidate"] in ("position", "velocity"):
            continue
        stem = r["candidate"].rsplit("/", 1)[-1].removesuffix(".pt")
        worst[stem] = max(worst.get(stem, 0.0), r["rmse_deg"] / velocity[r["scenario"]])
    return worst


def retrain(load: Callable[[str], object],
            table: Callable[[list[str], list[list[str]]], str], shipped: str) -> str:
    """The shipped policy against the same training command re-run on today's DON, on
    the validation clips (tracker_retrain.json)."""
    data = load("tracker_retrain")
    scenarios = ("exp2-servo", "exp3-forearm-low")
    cells: dict[str, dict[str, dict]] = {}
    for row in data["rows"]:
        name = row.get("command", row["candidate"].removesuffix("-hold"))
        cells.setdefault(name, {})[row["scenario"]] = row
    reference = cells["velocity"]
    lines = []
    for name, by_scenario in cells.items():
        rmse = [f"{by_scenario[s]['rmse_deg']:.2f}" for s in scenarios]
        if name in ("position", "velocity"):
            lines.append([name, *rmse, ""])
            continue
        worst = max(by_scenario[s]["rmse_deg"] / reference[s]["rmse_deg"] for s in scenarios)
        label = f"`{name}`" + (" (shipped)" if name == shipped else "")
        lines.append([label, *rmse, f"{worst:.3f}"])
    seeds = data["seeds"]
    tiebreak = _worse_ratios(load("tracker_tiebreak"))
    return f"""

The estimator changed after those choices (issue 3: DON's smoothing and threshold,
its pivot, the slow-link reading and the trust factor; then eta 0 before DON's first
reading, and omega and eta from the guesses made before the pivot is agreed), and the
candidates table above was measured on the DON of its day. So after each change the
default training command was run again on the new DON with SAC seeds 0 and 1, and both
compared with the policy shipped until then on the same validation clips
({seeds[0]}-{seeds[-1]}) by the same rule; the best was shipped. After the last change
(eta and omega before the pivot, faster pivot agreement) that was seed 1 (worse ratio
0.933; the old policy scored 1.50 deg on the servo, having learned the old start, and
seed 0 0.99: `benchmarks/results/tracker_retrain.json` at commit `ebf2715`). Then
variants of the reward balance and the residual scale were trained and compared with
it the same way: a residual scale of 0.3 did worse (1.23 and 19.67 deg) and seed 1
with balance 1.0 came out just below it (worse ratio 0.930 against 0.933; 0.87 and
18.41 deg; both in `benchmarks/results/tracker_variants.json`); seed 0 with balance
1.0, lowest of all, now the default, was shipped. Then DON gained its appearance layer
(`estimators/appearance.py`): its estimates changed, so the default command was run
again with SAC seeds 0 and 1 and compared with that policy the same way (the table
below; "velocity" and "position" are the scripted controllers on the same clips). The
lowest worse ratio was shipped. Then DON dropped its Gaussian (issue 3), and the same
was done again: the table below, that round. Seeds 0 and 1 tied on these clips (their
worse ratios differ in the fourth decimal), so both ran on thirty more validation clips,
910-939, and seed 1 had the lower worse ratio there, {tiebreak['s1']:.3f} against
{tiebreak['s0']:.3f} (`.venv/bin/python benchmarks/tracker_candidates.py <the two .pt
files> --seeds 910 ... 939 --json benchmarks/results/tracker_tiebreak.json`); it is
shipped. Command of the table: `.venv/bin/python benchmarks/tracker_candidates.py <the
.pt files> --json benchmarks/results/tracker_retrain.json`:

{table(["policy (training command)", "`exp2-servo` RMSE (deg)",
        "`exp3-forearm-low` RMSE (deg)", "worse ratio to velocity"], lines)}
"""
