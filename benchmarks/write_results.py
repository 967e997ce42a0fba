"""Write benchmarks/RESULTS.md from the measurements in benchmarks/results/*.json.

Run after `bash benchmarks/run_all.sh`; every figure in RESULTS.md then comes from those
files, with the command that produced it. Usage: .venv/bin/python benchmarks/write_results.py
"""

from __future__ import annotations

import json
from pathlib import Path

from results_tracking import render as render_tracking

HERE = Path(__file__).parent
RESULTS = HERE / "results"


def load(name: str):
    return json.loads((RESULTS / f"{name}.json").read_text())


def table(header: list[str], rows: list[list[str]]) -> str:
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(row) + " |" for row in rows]
    return "\n".join(lines)


def main() -> None:
    env, step, oracle = load("env"), load("step_profile"), load("oracle")
    don, evaluation = load("don"), load("eval")
    m = env["machine"]
    mean = {(r["scenario"], r["estimator"]): r for r in evaluation}

    def ev(scenario: str, estimator: str, key: str = "rmse_deg_settled") -> float:
        return mean[(scenario, estimator)]["mean"][key]

    def per_clip(scenario: str, estimator: str) -> str:
        rows = mean[(scenario, estimator)]["rows"]
        return ", ".join(f"{r['rmse_deg_settled']:.1f}" for r in rows)

    render = dict(env["render_frames_per_s"])
    reference = render.pop("mujoco_renderer_rgb")
    slow = sorted(name for name, fps in render.items() if fps < 150)
    out = [f"""# Measured results

Every figure here comes from a script in `benchmarks/`: `bash benchmarks/run_all.sh` (or
`make bench`) reruns them into `benchmarks/results/*.json`, and
`.venv/bin/python benchmarks/write_results.py` writes this file from those.

Machine: {m['cpu']}, {m['cores']} cores, no GPU, Python {m['python']}, MuJoCo {m['mujoco']},
Gymnasium {m['gymnasium']}, rendering with `MUJOCO_GL={m['MUJOCO_GL']}` (Mesa llvmpipe,
`LP_NUM_THREADS=1`). The machine is shared: absolute times move by tens of per cent from
run to run, which is why speed is reported against a reference measured in the same run
wherever there is one.

## Environment speed (issue 2)

Command: `.venv/bin/imimic bench env --json benchmarks/results/env.json`

ImitateVideo-v0 (default scenario, clip from the cache, the 240x320 frame copied into
every observation, through `gym.make`'s wrappers) against Gymnasium's `Reacher-v5`,
random actions, {env['steps']} steps a run, {env['repeats']} alternating runs each, medians:

{table(["env", "steps/s"], [["ImitateVideo-v0", f"{env['imitate_steps_per_s']:.0f}"],
                            ["Reacher-v5", f"{env['reacher_steps_per_s']:.0f}"],
                            ["**ratio**", f"**{env['ratio']:.2f}** (target >= 0.5)"]])}

Where a step goes. Command: `.venv/bin/python benchmarks/step_profile.py --json
benchmarks/results/step_profile.json`

{table(["part of a step", "us"], [
        ["whole `env.step` through `gym.make`", f"{step['step_us']:.0f}"],
        [f"physics, {step['substeps']} substeps of {step['physics_step_ms']:.2f} ms",
         f"{step['physics_us']:.0f}"],
        ["physics if the substep were 2 ms (17 substeps)", f"{step['physics_2ms_us']:.0f}"],
        ["observation (frame copy, state)", f"{step['observation_us']:.0f}"],
        ["info (target, error)", f"{step['info_us']:.0f}"]])}

The substep is the largest that divides a frame and stays under 5.6 ms. The position servo
following a 0.5 Hz sine sampled at 30 fps lags by at most
{step['servo_max_error_deg']:.2f} degrees with it and {step['servo_max_error_2ms_deg']:.2f} with 2 ms
substeps: the larger step costs no accuracy.

## Clip rendering (issue 2)

Same command. Frames per second at 240x320 rendering a 150-frame clip from scratch (no
cache), ground truth included (keypoints, visibility, occlusion, depth), median of 3
rounds. The reference, measured in the same run: `mujoco.Renderer` drawing plain RGB
frames of the default scene, no truth: {reference:.0f} frames/s.

{table(["scenario", "frames/s", "vs mujoco.Renderer RGB"],
       [[f"`{k}`", f"{v:.0f}", f"{v / reference:.2f}"] for k, v in render.items()])}

Target: at least 150 frames/s. In this run: {"met by every scenario." if not slow else
"met by every scenario except " + ", ".join(f"`{s}`" for s in slow) + "."} Absolute
frame rates move by a quarter between runs on this shared machine (the `default` scenario
has measured from 156 to 276 frames/s), which is why the same-run reference is there. A
frame with its full truth costs {reference / render['default']:.1f}x a plain RGB frame of the same scene. A
profile of `render_clip` shows where it goes: reading colour and depth back together (the
largest single part; the depth truth and the keypoint visibility need it), drawing,
converting depth, per-frame bookkeeping and, in the occluder scenes, the occlusion pass.
Scenes with an occluder need a second render pass (the moving links alone, as
segmentation and depth) to measure how much of the arm is hidden, in the frames where the
board's image overlaps the arm's; on the software renderer a pass has a fixed cost even
when it draws two geoms and reads back only the box around the arm. A rendered clip is
cached, so this is paid once per clip.

What makes rendering fast (each measured while building it, one at a time; the table is
the result of all of them): no MSAA (`offsamples=0`), one llvmpipe thread (at 240x320
handing tiles between threads costs more than it saves), colour and depth read back from
one pass, keypoint visibility by a z-test against that depth instead of a segmentation
pass, the occlusion pass only where the board can overlap the arm, and thin boxes instead
of MuJoCo planes and textures for the walls and floor (planes are drawn as many lit quads).

## Oracle tracking: the control loop's upper bound (issue 2)

Command: `.venv/bin/python benchmarks/oracle_tracking.py --json benchmarks/results/oracle.json`

`OracleController` (a `PDController` fed the true angles one frame ahead), full 150-frame
clips, held-out clip seeds {oracle['seeds']}; mean RMSE and lag over the seeds, largest
error over all of them. No vision: this is what a perfect estimator would allow.

{table(["scenario", "control", "RMSE (deg)", "max error (deg)", "lag (frames)"],
       [[f"`{r['scenario']}`", r["control"], f"{r['rmse_deg']:.2f}", f"{r['max_error_deg']:.2f}",
         f"{r['lag_frames']:.1f}"] for r in oracle["rows"]])}

Acceptance: oracle with position control on `exp2-servo` at most 2 degrees RMSE: met
(also asserted by `tests/controllers/test_scripted.py` on other seeds).

Reading the table:
- The three `exp3-forearm-*` rows are identical on purpose: a clip's motion depends only
  on its seed, so the occlusion levels share the same arm motion and differ only in what
  the camera sees. Estimators are compared on equal motion.
- Torque control is the weakest: `PDController` closes its loop once per video frame
  (30 Hz), so its bandwidth stays at 4 Hz, and it has no acceleration feed-forward (the
  computed-torque controller with an estimator's alpha is issue 5's job).
- `exp1-noisy-fast` (the paper's failed experiment) is hard even for the oracle with
  velocity or torque control: its movements last 0.15-0.35 s.

## DON and the baselines (issue 3, in progress)

Not done. This section records where DON stands, measured. DON handles one moving link;
the prediction layer is implemented but off by default (see below).

### Speed: the paper's Table 1 on equal frames

Command: `.venv/bin/imimic bench don --json benchmarks/results/don.json`

Milliseconds per frame, one OpenCV thread, the same rendered frames of the `default`
scenario ({don['frames']} frames), median of {don['repeats']} alternating runs. "MOG2 raw" is OpenCV's
`BackgroundSubtractorMOG2.apply` on the full frame (the paper's comparison); the
"estimator" columns are the full baselines (working resolution, link geometry) used in
the accuracy comparison below.

{table(["resolution", "DON", "MOG2 estimator", "CamShift estimator", "MOG2 raw", "DON / MOG2 raw"],
       [[r["resolution"], f"{r['don_ms']:.2f}", f"{r['mog2_estimator_ms']:.2f}",
         f"{r['camshift_estimator_ms']:.2f}", f"{r['mog2_raw_ms']:.2f}", f"{r['ratio_mog2']:.2f}"]
        for r in don["rows"]])}

Target: DON at most 0.3x MOG2 at every resolution. {", ".join(
    f"{r['resolution']}: {'met' if r['ratio_mog2'] <= 0.3 else '**not met**'}" for r in don['rows'])}.
DON costs about a millisecond at any resolution (it works at 120 rows); at 240x320 raw
MOG2 costs only one to two and a half (it moves that much between runs on this machine).
What is left of DON's millisecond is spread over many small numpy calls per frame
(moving-region moments, the link geometry, building the estimate), not one hot spot;
reaching 0.3x at 240x320 needs fewer, larger array operations per frame.

Paper Fig. 3 (same command): `benchmarks/results/don_window.png` plots time per frame
against N from 2 to 20: flat, because the union over the window is kept incrementally
(the paper's time grows with N). `benchmarks/results/don_lighting.png` plots moving
pixels detected against light intensity: near zero at 0.2-0.3, rising steadily after, in
line with the paper's "works above 50%".

### Accuracy on held-out clips

Command: `.venv/bin/imimic eval --scenario exp2-servo default exp3-forearm-none
exp3-forearm-low exp3-forearm-high exp1-noisy-fast --estimator don mog2 camshift
--episodes 3 --json benchmarks/results/eval.json`

Estimator-only (no robot), clip seeds 1000-1002 (tests and development use seeds below
1000), 150 frames each. "Settled" leaves out the first 0.5 s: a frame-differencing
estimator sees nothing before the arm moves. Lag: cross-correlation peak, in frames.

{table(["scenario", "estimator", "RMSE (deg)", "settled RMSE (deg)", "lag", "mean eta"],
       [[f"`{r['scenario']}`", r["estimator"], f"{r['mean']['rmse_deg']:.2f}",
         f"{r['mean']['rmse_deg_settled']:.2f}", f"{r['mean']['lag_frames']:.1f}",
         f"{r['mean']['mean_trust']:.2f}"] for r in evaluation])}

Occluded frames (over 10% of the moving links hidden), DON with the prediction layer off
and on (trust threshold 0.3):

{table(["scenario", "prediction off (deg)", "prediction on (deg)"],
       [[f"`{r['scenario']}`", f"{r['mean']['rmse_occluded_deg_prediction_off']:.1f}",
         f"{r['mean']['rmse_occluded_deg_prediction_on']:.1f}"]
        for r in evaluation if "rmse_occluded_deg_prediction_on" in r["mean"]])}

Against issue 3's acceptance:
- `exp2-servo` at most 3 degrees and at most 2 frames of lag: **met** after the 0.5 s
  warm-up ({ev('exp2-servo', 'don'):.2f} degrees, lag {ev('exp2-servo', 'don', 'lag_frames'):.0f}; over all frames
  {ev('exp2-servo', 'don', 'rmse_deg'):.2f}, all of it in the first half second).
- `exp3-forearm-none` at most 4 degrees: **not met** ({ev('exp3-forearm-none', 'don'):.1f}). The moving
  distractor ball and the body sway put other moving regions next to the forearm.
- `exp3-forearm-high` at most 10 degrees: **not met** ({ev('exp3-forearm-high', 'don'):.1f}; per clip
  {per_clip('exp3-forearm-high', 'don')}). The board's own moving edges are long straight regions
  too. DON takes a first pivot only when two solves agree and afterwards refines it only
  from regions it accepts as the forearm; that took `exp3-forearm-low` from 88 to 26
  degrees. Where the remaining error comes from, frame by frame, is not traced yet.
- Trust factor strictly decreasing from none to low to high occlusion: **not met**; mean
  eta {ev('exp3-forearm-none', 'don', 'mean_trust'):.2f}, {ev('exp3-forearm-low', 'don', 'mean_trust'):.2f}, {ev('exp3-forearm-high', 'don', 'mean_trust'):.2f}. eta is the paper's formula with M_p the link's
  area per radian turned (the raw area grows with speed); on these clips it still
  follows the motion more than the occlusion.
- Prediction layer lowering RMSE on occluded frames: **not met**; switched on it raises
  the error (table above), so it is off by default.
- DON beats MOG2 and CamShift on `exp3-forearm-low`: **met** ({ev('exp3-forearm-low', 'don'):.1f} against
  {ev('exp3-forearm-low', 'mog2'):.1f} and {ev('exp3-forearm-low', 'camshift'):.1f}; per clip DON {per_clip('exp3-forearm-low', 'don')}, MOG2
  {per_clip('exp3-forearm-low', 'mog2')}, CamShift {per_clip('exp3-forearm-low', 'camshift')}). DON also beats both on `exp2-servo` and
  `exp3-forearm-high`. CamShift wins on `default`, where skin against a plain wall is an
  easy colour to follow, and fails wherever the arm has no distinct hue (the paper link);
  MOG2 is slightly better than DON on `exp3-forearm-none`.
- `exp4-hand` (the paper's experiment 4: forearm, thumb and index finger): the scenario
  and its matching branching robot exist (the oracle table above tracks it); DON for its
  three joints, like DON for the 2-link chain, is not built yet, so it has no DON row.
"""]
    out.append(render_tracking(load, table))
    (HERE / "RESULTS.md").write_text("".join(out))


if __name__ == "__main__":
    main()
