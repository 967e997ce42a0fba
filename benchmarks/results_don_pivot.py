"""RESULTS.md text: how much of DON's error on the person clips is the pivot
(benchmarks/don_known_pivot.py)."""

from __future__ import annotations


def render(load, table) -> str:
    data = load("don_known_pivot")
    rows = []
    for r in data["results"]:
        m = r["mean"]
        rows.append([f"`{r['scenario']}`", f"{m['rmse_deg_settled_pivot_found']:.1f}",
                     f"{m['rmse_deg_settled_pivot_given']:.1f}",
                     f"{m['pivot_error_px_median']:.0f}", str(m["pivot_never_found"])])
    intro = ("  Where the error comes from. Mostly the pivot: told where the elbow is, DON's "
             "error on\n  the same clips falls by a quarter to a half (command: "
             f"`{data['command']}`):")
    return f"""{intro}

{table(["scenario", "settled RMSE, pivot found (deg)", "pivot given (deg)",
        "found pivot off by (input px, median)", "clips without a pivot"], rows)}

  The pivot is the mode of the crossings of the moving regions' axes. On the occluder
  clips the occluder's vertical edges fill that memory of lines and cross the forearm's
  lines far from the elbow; on `exp3-forearm-none` the forearm often turns within a
  narrow fan, whose lines cross at shallow angles and fix the pivot poorly along the
  forearm. With the pivot given, what is left is slow motion: a forearm turning under a
  degree per frame leaves no moving pixels along it in consecutive frames at all (traced
  frame by frame), so DON holds its last angle. Each of these was tried this session on
  development clips (seeds 0-19) and not kept, because each was better on some
  scenarios and worse on others: Hough-style voting of every region along its axis per
  direction bin (pivots closer, but agreed 50-130 frames later); a RANSAC consensus
  pivot scored by the spread of its lines' directions (`exp3-forearm-none` 14.5 -> 11.7
  and `exp1-noisy-fast` 32 -> 26 degrees, but `exp3-forearm-low` 28.7 -> 32.7); a prior
  pulling the pivot to the slivers' inner ends (broke `exp2-servo`); dropping families
  of parallel lines at different offsets (a translating edge) before the solve;
  differences to frames 3, 6 and 10 back where the newest one shows nothing along the
  link (pivot given: `exp3-forearm-low` 11.6 -> 8.9; pivot found: worse); and, in
  earlier sessions, a bearing-only reading of compact regions, closing or dilating the
  mask, and dropping the pivot after 15 frames without the link. Kept: a moving region
  reaching more than 2 px back past the pivot is not the link (an occluder's edge
  sweeping across the joint does that; a sliver of the turning link does not), and the
  radius gate drops after 5 frames without a match, like the direction gate (a radius
  measured on a stray first region locked the forearm out of a whole clip). Over these
  held-out clips those two moved DON's settled RMSE on `exp3-forearm-low` from 27.4 to
  24.4 degrees and on `exp3-forearm-high` from 29.4 to 28.5; the other scenarios did not
  change by more than 0.6 degrees."""
