"""RESULTS.md text under DON's speed table (issue 3): where DON's time per frame goes,
stage by stage. Rendered from benchmarks/results/don_stages.json; called by
write_results.py."""

from __future__ import annotations

from collections.abc import Callable


def render(load: Callable[[str], dict],
           table: Callable[[list[str], list[list[str]]], str]) -> str:
    stages = load("don_stages")
    rows = [[name.strip(), f"{us:.0f}"] for name, us in stages["stages_us_per_frame"].items()]
    bench = next(row for row in load("don")["rows"] if row["resolution"] == stages["resolution"])
    return f"""
At {stages['resolution']} the margin is small: on this shared 2-core machine, DON / raw
MOG2 there measured {bench['ratio_mog2']:.2f} in the bench above and
{stages['ratio_mog2_median']:.2f} (medians; {stages['ratio_mog2_min']:.2f} of minima) over
{stages['repeats']} alternations of the stage script below.

Where DON's time goes at {stages['resolution']}. Command: `.venv/bin/python benchmarks/don_stages.py
--json benchmarks/results/don_stages.json`. us per frame of each stage, its least disturbed total
over {stages['repeats']} runs of the {stages['frames']} frames; nested stages count in their caller
too (`component_lines` in the lines of regions, pivot solves in the lines and the estimate's
keypoints), and each timer adds {stages['timer_overhead_us_per_call']:.1f} us per call.

{table(["stage", "us per frame"], rows)}

Unwrapped, in the same runs: DON {stages['don_ms_median']:.3f} ms per frame (median; minimum
{stages['don_ms_min']:.3f}) against raw MOG2's {stages['mog2_raw_ms_median']:.3f}. Most of it is
the first layer (downscale of the full frame, then a 3x3 Gaussian: a fixed cost of the input),
then labelling the moving regions (`component_lines`), the differences and sliding extrema, and
the periodic pivot solve. This session's accuracy work (a smaller Gaussian and threshold, the
sliding-edge test, the slow-link difference, the densest-block start of the pivot's mean shift)
first made a frame slower; the slow-link difference now covers only the square the link
can reach, the sliding-edge test runs in scalars, and an agreed pivot is re-solved every 20 of
the link's lines instead of 10. `benchmarks/don_same_estimates.py --base REV` checks that a
change left every estimate as it was at REV (it did not this session: the estimates changed on
purpose).
"""
