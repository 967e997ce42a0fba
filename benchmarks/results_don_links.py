"""The DON-for-several-links section of RESULTS.md (issue 3, items 1 and 5), rendered from
benchmarks/results/don_links.json; `write_results.py` appends it."""

from __future__ import annotations

import json
from pathlib import Path

RESULTS = Path(__file__).parent / "results"
JOINTS = {"chain-2": ("shoulder", "elbow"), "chain-3": ("shoulder", "elbow", "wrist"),
          "exp4-hand": ("forearm (elbow)", "thumb", "index finger")}
HEADER = ("| scenario | estimator | settled RMSE (deg) | per joint (deg) | lag (frames) "
          "| mean eta | per clip (deg) |\n|---|---|---|---|---|---|---|")
ACCEPT_DEG = 6.0  # issue 3: a 2-link chain at most 6 degrees per joint


def don_links_section() -> str:
    """Markdown: per-joint settled RMSE of `LinkedDON` on the several-link scenarios."""
    path = RESULTS / "don_links.json"
    if not path.exists():
        return ""
    results = json.loads(path.read_text())
    rows = []
    for r in results:
        m = r["mean"]
        names = JOINTS.get(r["scenario"], ())
        per_joint = ", ".join(f"{name} {m[f'rmse_deg_settled_q{i + 1}']:.1f}"
                              for i, name in enumerate(names))
        clips = ", ".join(f"{row['rmse_deg_settled']:.1f}" for row in r["rows"])
        rows.append(f"| `{r['scenario']}` | {r['estimator']} | {m['rmse_deg_settled']:.2f} | "
                    f"{per_joint} | {m['lag_frames']:.1f} | {m['mean_trust']:.2f} | {clips} |")
    results = [r for r in results if r["estimator"] == "don"]
    chain = next((r["mean"] for r in results if r["scenario"] == "chain-2"), None)
    verdict = ""
    if chain is not None:
        worst = max(chain["rmse_deg_settled_q1"], chain["rmse_deg_settled_q2"])
        met = "**met**" if worst <= ACCEPT_DEG else "**not met**"
        verdict = (f"\nAcceptance \"2-link chain at most {ACCEPT_DEG:.0f} degrees per joint\": "
                   f"{met} (worst joint {worst:.1f} degrees). `exp4-hand` is reported per "
                   "joint above.\n")
    speed = ""
    speed_path = RESULTS / "don_links_speed.json"
    if speed_path.exists():
        data = json.loads(speed_path.read_text())
        lines = [f"| `{r['scenario']}` | {r['links']} | {r['don_ms']:.2f} | {r['linked_ms']:.1f} | "
                 f"{r['ratio_linked_to_don']:.0f} |" for r in data["rows"]]
        ratios = [r["ratio_linked_to_don"] for r in data["rows"]]
        low, high = min(ratios), max(ratios)
        slowest = max(r["linked_ms"] for r in data["rows"])
        within = "within" if slowest < 1000 / 30 else "beyond"
        speed = f"""
Speed: `.venv/bin/python benchmarks/don_links_speed.py --json
benchmarks/results/don_links_speed.json`. Milliseconds per {data['resolution']} frame, one
thread, median of {data['repeats']} alternating runs over the same {data['frames']} frames
(clip seed 1000); the one-link DON on the same frames is the reference.

| scenario | links | one-link DON (ms) | LinkedDON (ms) | LinkedDON / DON |
|---|---|---|---|---|
{chr(10).join(lines)}

The fit scores hundreds of candidate poses against a few hundred moving pixels each
frame, where the one-link DON fits a line to each moving region once: {low:.0f} to
{high:.0f} times slower; the slowest, {slowest:.1f} ms, is {within} a 30 fps frame's 33 ms.
"""
    shoulder = _shoulder_given()
    first, episodes = results[0]["first_seed"], results[0]["episodes"]
    worst_clip = max(row["rmse_deg_settled"] for r in results if r["scenario"] == "chain-2"
                     for row in r["rows"])
    return f"""
## DON for several links (issue 3: object regression layer, n links)

Command: `.venv/bin/imimic eval --scenario chain-2 chain-3 exp4-hand --estimator don
don-paper --episodes {episodes} --json benchmarks/results/don_links.json`

`LinkedDON` (`imimic_gym/estimators/don_links.py`): each frame, the joint angles whose
polyline best explains DON's moving pixels l_1; the root pivot and the link lengths found
from the video (nothing given). Then (`don`, the default) the appearance layer reads each
link 12 working px or longer along its colour; `don-paper` is the paper's layers alone
(`LinkedDON(appearance=False)`). Estimator only, clip seeds {first}-{first + episodes - 1}
(the rules were chosen on seeds below 1000: `benchmarks/don_links_dev_seeds.py`), 150
frames each, means over the clips; settled RMSE leaves out the first 0.5 s, as in the
one-link table. Each joint's angle is relative to its parent link. MOG2 and CamShift stay
one-link and are not run here.

{HEADER}
{chr(10).join(rows)}
{verdict}
Where the error comes from (seen on the development clips): the fit places the elbow on
the forearm's line where the upper arm's measured length puts it, and the upper arm's
blue sleeve barely differs from the blue-grey checks behind it, so its length is measured
mostly from the forearm's pixels; the appearance layer reads each link's direction from
its colour instead, which needs no length. Over the first frames the place where the
moving arm's far ends recur was usually its hand, not its shoulder, and the pose fitted
about it locked 100 degrees off; the pivot must now be a place from which the arm reaches
where the shoulder can turn it (`don_links.facing_point`). About a found shoulder a few
pixels off, the fit's upper arm runs 10-15 degrees off for dozens of frames; the
appearance layer reads it right from its colour, and no longer drops that colour for
disagreeing with the fit (it did every five frames, each time leaving the next frame to
the fit: on development clips this alone took `chain-3` from 10.6/14.5/22.1 to
3.5/8.5/20.4 degrees per joint, `chain-2` from 3.3/3.9 to 2.1/2.7). What is left: the found
shoulder sits a few pixels below the true one, where the arm leaves the torso's outline
(below); the first second goes on finding the pivot and the lengths; and some clips lock
onto a wrong pose for a while before a search over the whole ranges recovers it (the
`chain-2` clip at {worst_clip:.1f} degrees above). The appearance layer searches near the
fitted pose, so it cannot undo a wrong lock.
{shoulder}{speed}"""


def _shoulder_given() -> str:
    """Markdown: `chain-2` with the shoulder found and given (don_known_pivot.json)."""
    path = RESULTS / "don_known_pivot.json"
    chains = json.loads(path.read_text()).get("chains", []) if path.exists() else []
    chain = next((r for r in chains if r["scenario"] == "chain-2"), None)
    if chain is None:
        return ""
    m = chain["mean"]
    rows = [f"| {how} | " + " | ".join(f"{rmse:.1f} ({bias:+.1f})" for rmse, bias in
                                         zip(m[key]["rmse_deg_settled"],
                                             m[key]["mean_error_deg"], strict=True)) + " |"
            for how, key in (("found (as above)", "pivot_found"),
                             ("given (the true shoulder)", "pivot_given"))]
    worst_given = max(m["pivot_given"]["rmse_deg_settled"])
    worst_found = max(m["pivot_found"]["rmse_deg_settled"])
    if worst_given > ACCEPT_DEG:
        verdict = f"With the true shoulder the worse joint is still {worst_given:.1f} degrees."
    elif worst_found > ACCEPT_DEG:
        verdict = (f"With the true shoulder both joints are within {ACCEPT_DEG:.0f} degrees "
                   f"(worse {worst_given:.1f}): what stands between `LinkedDON` and the "
                   "issue's bar is the shoulder it finds.")
    else:
        verdict = (f"Both ways the joints are within {ACCEPT_DEG:.0f} degrees; the found "
                   f"shoulder costs {worst_found - worst_given:.1f} degrees at the worse "
                   "joint (per clip below).")
    per_clip = ", ".join(f"{max(r['pivot_found']['rmse_deg_settled']):.1f} / "
                         f"{max(r['pivot_given']['rmse_deg_settled']):.1f}"
                         for r in chain["rows"])
    return f"""
The shoulder given. Command: `.venv/bin/python benchmarks/don_known_pivot.py --json
benchmarks/results/don_known_pivot.json` (the same held-out clips; the found shoulder
lies {m['pivot_error_px_median']:.0f} input px from the true one, median). Settled RMSE per
joint, deg, with the mean signed error (estimate minus truth) in brackets:

| shoulder | shoulder joint | elbow joint |
|---|---|---|
{chr(10).join(rows)}

{verdict}
Per clip, shoulder found / given (worse joint, deg): {per_clip}.
"""
