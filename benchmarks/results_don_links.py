"""The DON-for-several-links section of RESULTS.md (issue 3, items 1 and 5), rendered from
benchmarks/results/don_links.json; `write_results.py` appends it."""

from __future__ import annotations

import json
from pathlib import Path

RESULTS = Path(__file__).parent / "results"
JOINTS = {"chain-2": ("shoulder", "elbow"), "chain-3": ("shoulder", "elbow", "wrist"),
          "exp4-hand": ("forearm (elbow)", "thumb", "index finger")}
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
        rows.append(f"| `{r['scenario']}` | {m['rmse_deg_settled']:.2f} | {per_joint} | "
                    f"{m['lag_frames']:.1f} | {m['mean_trust']:.2f} | {clips} |")
    chain = next((r["mean"] for r in results if r["scenario"] == "chain-2"), None)
    verdict = ""
    if chain is not None:
        worst = max(chain["rmse_deg_settled_q1"], chain["rmse_deg_settled_q2"])
        met = "**met**" if worst <= ACCEPT_DEG else "**not met**"
        verdict = (f"\nAcceptance \"2-link chain at most {ACCEPT_DEG:.0f} degrees per joint\": "
                   f"{met} (worst joint {worst:.1f} degrees). `exp4-hand` is reported per "
                   "joint above.\n")
    first, episodes = results[0]["first_seed"], results[0]["episodes"]
    worst_clips = " and ".join(
        f"{v:.1f}" for v in sorted((row["rmse_deg_settled"] for r in results
                                    if r["scenario"] == "chain-2" for row in r["rows"]),
                                   reverse=True)[:2])
    return f"""
## DON for several links (issue 3: object regression layer, n links)

Command: `.venv/bin/imimic eval --scenario chain-2 chain-3 exp4-hand --estimator don
--episodes {episodes} --json benchmarks/results/don_links.json`

`LinkedDON` (`imimic_gym/estimators/don_links.py`): each frame, the joint angles whose
polyline best explains DON's moving pixels l_1; the root pivot and the link lengths found
from the video (nothing given). Estimator only, clip seeds {first}-{first + episodes - 1}
(tuning used seeds 0-9), 150 frames each, means over the clips; settled RMSE leaves out
the first 0.5 s, as in the one-link table. Each joint's angle is relative to its parent
link. MOG2 and CamShift stay one-link and are not run here.

| scenario | settled RMSE (deg) | per joint (deg) | lag (frames) | mean eta | per clip (deg) |
|---|---|---|---|---|---|
{chr(10).join(rows)}
{verdict}
Where the error comes from (seen on the tuning clips): the found shoulder sits a few pixels
below the true one, where the arm leaves the torso's outline; the upper arm's blue sleeve
barely differs from the blue-grey checks behind it, so while it turns slowly the elbow is
placed mostly by the forearm's pixels, and there a pixel of upper-arm length is degrees;
the first second goes on finding the pivot and the lengths, and some clips lock onto a
wrong pose for a while before a search over the whole ranges recovers it (the
`chain-2` clips at {worst_clips} degrees above). Even with the true shoulder and true
lengths given, the best-explaining polyline was a few degrees off on tuning clips: the
moving pixels of a slowly turning link lie mostly on one side of it, where the checks
behind it contrast more.
"""
