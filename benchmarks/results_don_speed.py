"""RESULTS.md text under DON's speed table (issue 3): where DON's time per frame goes,
stage by stage, before and after the speed work, and the check that its estimates did
not change. Rendered from benchmarks/results/don_stages.json, don_stages_before.json and
don_same_estimates.json; called by write_results.py."""

from __future__ import annotations

from collections.abc import Callable


def render(load: Callable[[str], dict],
           table: Callable[[list[str], list[list[str]]], str]) -> str:
    after, before, same = load("don_stages"), load("don_stages_before"), load("don_same_estimates")
    stages = list(after["stages_us_per_frame"])
    rows = [[name.strip(), f"{before['stages_us_per_frame'].get(name, float('nan')):.0f}",
             f"{after['stages_us_per_frame'][name]:.0f}"] for name in stages]
    differences = ", ".join(f"{field} {value:.1e}"
                            for field, value in same["max_abs_difference"].items() if value)
    scenarios = ", ".join(f"`{name}`" for name in same["scenarios"])
    identical = ("bit-identical: every field of every estimate, and every frame's count of "
                 "moving pixels, equal to the last bit" if same["bit_identical"]
                 else f"not bit-identical; largest differences: {differences}")
    bench = next(row for row in load("don")["rows"] if row["resolution"] == after["resolution"])
    return f"""
At {after['resolution']} the margin is small: on this shared 2-core machine,
DON / raw MOG2 there measured {bench['ratio_mog2']:.2f} in the bench above and
{after['ratio_mog2_median']:.2f} (medians; {after['ratio_mog2_min']:.2f} of minima) over
{after['repeats']} alternations of the stage script below.

Where DON's time goes at {after['resolution']}. Command: `.venv/bin/python benchmarks/don_stages.py
--json benchmarks/results/don_stages.json`, and the same script run on the code before the speed
work (`git archive {same['base_commit'][:10]} imimic_gym` unpacked into a folder on
`PYTHONPATH`) for `don_stages_before.json`. us per frame of each stage, its least disturbed total
over {after['repeats']} runs of the {after['frames']} frames; nested stages count in their caller
too (`component_lines` in the lines of regions, pivot solves in the lines and the estimate's
keypoints), and each timer adds {after['timer_overhead_us_per_call']:.1f} us per call. The runs
were separate, on a machine shared with another job: compare the ratios, each against raw MOG2
timed in its own run.

{table(["stage", "before (us)", "after (us)"], rows)}

Unwrapped, in the same runs: DON {before['don_ms_median']:.3f} -> {after['don_ms_median']:.3f} ms
per frame (medians; minima {before['don_ms_min']:.3f} -> {after['don_ms_min']:.3f}) against raw
MOG2's {before['mog2_raw_ms_median']:.3f} and {after['mog2_raw_ms_median']:.3f}: ratio
{before['ratio_mog2_median']:.3f} -> {after['ratio_mog2_median']:.3f}. What changed: moving
regions are labelled inside their bounding box (cropped on even coordinates, so OpenCV numbers
them as before) and their moments summed as exact integers (directly when the box holds one
region); the union of delta2 is formed only
inside delta1's bounding box; the link's location, the trust factor, the principal axes and the
estimate's checks run in scalar arithmetic instead of numpy calls on 1- to 3-element arrays; the
pivot solve reuses its pair indices and skips `np.average`'s checks. What is left is mostly the
first layer (downscale of the full frame, then a 5x5 Gaussian: a fixed cost of the input), then
labelling the moving regions (`component_lines`), the differences and sliding extrema, and the
periodic pivot solve.

Same estimates: `.venv/bin/python benchmarks/don_same_estimates.py --base {same['base']}`
compares DON at `{same['base_commit'][:10]}` with this tree on {scenarios},
seeds {same['seeds'][0]}-{same['seeds'][-1]}, each as the bench runs it, as `imimic eval` does,
with the robot's torques and the prediction layer on, and on the depth video: {identical}.
"""
