"""The paper's experiments 1-4 as runs of the evaluation suite, and the table that sets
our numbers beside what the paper states (`imimic eval --paper`)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from imimic_gym.suite import RunConfig

__all__ = ["PAPER_EXPERIMENTS", "PaperExperiment", "paper_configs", "paper_table"]


@dataclass(frozen=True)
class PaperExperiment:
    """One of the paper's experiments: our scenario, the estimator we can run on it, and
    what the paper reports (its words; it gives no angle errors, only these statements and
    the trust-factor ranges of experiment 3)."""

    name: str
    scenario: str
    estimator: str
    paper_says: str
    note: str = ""
    compare: Callable[[dict[str, Any]], str] = field(default=lambda mean: "-")


def _eta_in(low: float, high: float) -> Callable[[dict[str, Any]], str]:
    def compare(mean: dict[str, Any]) -> str:
        eta = mean["mean_trust"]
        inside = "inside" if low <= eta <= high else "outside"
        return f"eta {eta:.2f}, {inside} the paper's {low}-{high}"

    return compare


def _fails(mean: dict[str, Any]) -> str:
    return ("fails here too (RMSE over 20 deg)" if mean["rmse_deg"] > 20
            else "tracks where the paper failed")


def _near_perfect(mean: dict[str, Any]) -> str:
    return "near perfect (RMSE at most 4 deg)" if mean["rmse_deg"] <= 4 else "not near perfect"


PAPER_EXPERIMENTS = (
    PaperExperiment("exp1", "exp1-noisy-fast", "don",
                    "DON failed: fast random motion with body sway", compare=_fails),
    PaperExperiment("exp2", "exp2-servo", "don", "servo arm copied near perfectly",
                    compare=_near_perfect),
    PaperExperiment("exp3 none", "exp3-forearm-none", "don", "tracked, eta 0.9-1",
                    compare=_eta_in(0.9, 1.0)),
    PaperExperiment("exp3 low", "exp3-forearm-low", "don", "tracked, eta 0.5-0.7",
                    compare=_eta_in(0.5, 0.7)),
    PaperExperiment("exp3 high", "exp3-forearm-high", "don", "tracked, eta 0.3-0.4",
                    compare=_eta_in(0.3, 0.4)),
    PaperExperiment("exp4", "exp4-hand", "don", "forearm, thumb, index finger tracked",
                    note="DON for several links (LinkedDON); per joint in RESULTS.md"),
)
PAPER_CONTROLLERS = ("position", "learned")  # the paper's servo setting, and ours


def paper_configs(seeds: tuple[int, ...], frames: int | None = None,
                  controllers: tuple[str, ...] = PAPER_CONTROLLERS) -> list[RunConfig]:
    """Every experiment with each controller; multi-link experiments only with the
    controllers that drive several joints (the learned policy is one-link)."""
    from imimic_gym.clips.scenarios import get_scenario

    configs = []
    for experiment in PAPER_EXPERIMENTS:
        one_link = get_scenario(experiment.scenario).n_links == 1
        for controller in controllers:
            if controller == "learned" and not one_link:
                continue
            configs.append(RunConfig(experiment.scenario, experiment.estimator, controller,
                                     seeds, frames))
    return configs


def paper_table(results: list[dict[str, Any]]) -> str:
    """Markdown: one row per experiment and controller, our figures beside the paper's."""
    by_key = {(r["scenario"], r["controller"]): r for r in results}
    lines = ["| experiment | scenario | estimator | controller | RMSE (deg) | lag (frames) | "
             "mean eta | paper | here | note |", "|" + "---|" * 10]
    for experiment in PAPER_EXPERIMENTS:
        for (scenario, controller), result in by_key.items():
            if scenario != experiment.scenario:
                continue
            mean = result["mean"]
            eta = "-" if mean["mean_trust"] is None else f"{mean['mean_trust']:.2f}"
            lines.append(f"| {experiment.name} | `{scenario}` | {result['estimator']} | "
                         f"{controller} | {mean['rmse_deg']:.2f} | {mean['lag_frames']:.1f} | "
                         f"{eta} | {experiment.paper_says} | {experiment.compare(mean)} | "
                         f"{experiment.note} |")
    return "\n".join(lines)
