"""The paper table's verdicts, on hand-made figures either side of each threshold."""

from typing import Any

import pytest

from imimic_gym.paper import PAPER_EXPERIMENTS, paper_configs, paper_table


def experiment(name: str):
    (found,) = [e for e in PAPER_EXPERIMENTS if e.name == name]
    return found


def figures(rmse_deg: float = 10.0, mean_trust: float | None = 0.5) -> dict[str, Any]:
    return {"rmse_deg": rmse_deg, "lag_frames": 1.0, "mean_trust": mean_trust}


@pytest.mark.parametrize(("rmse_deg", "verdict"), [
    (20.5, "fails here too (RMSE over 20 deg)"),
    (20.0, "tracks where the paper failed"),
    (19.5, "tracks where the paper failed"),
])
def test_experiment_1_fails_only_over_20_degrees(rmse_deg: float, verdict: str) -> None:
    assert experiment("exp1").compare(figures(rmse_deg)) == verdict


@pytest.mark.parametrize(("rmse_deg", "verdict"), [
    (3.9, "near perfect (RMSE at most 4 deg)"),
    (4.0, "near perfect (RMSE at most 4 deg)"),
    (4.1, "not near perfect"),
])
def test_experiment_2_is_near_perfect_up_to_4_degrees(rmse_deg: float, verdict: str) -> None:
    assert experiment("exp2").compare(figures(rmse_deg)) == verdict


@pytest.mark.parametrize(("name", "eta", "verdict"), [
    ("exp3 none", 0.85, "eta 0.85, outside the paper's 0.9-1.0"),
    ("exp3 none", 0.9, "eta 0.90, inside the paper's 0.9-1.0"),
    ("exp3 none", 0.97, "eta 0.97, inside the paper's 0.9-1.0"),
    ("exp3 low", 0.45, "eta 0.45, outside the paper's 0.5-0.7"),
    ("exp3 low", 0.6, "eta 0.60, inside the paper's 0.5-0.7"),
    ("exp3 low", 0.75, "eta 0.75, outside the paper's 0.5-0.7"),
    ("exp3 high", 0.25, "eta 0.25, outside the paper's 0.3-0.4"),
    ("exp3 high", 0.35, "eta 0.35, inside the paper's 0.3-0.4"),
    ("exp3 high", 0.45, "eta 0.45, outside the paper's 0.3-0.4"),
])
def test_experiment_3_says_whether_eta_is_in_the_papers_range(name: str, eta: float,
                                                              verdict: str) -> None:
    assert experiment(name).compare(figures(mean_trust=eta)) == verdict


def test_the_table_puts_each_verdict_on_its_experiments_row() -> None:
    results = [
        {"scenario": "exp1-noisy-fast", "controller": "position", "estimator": "don",
         "mean": figures(rmse_deg=25.0, mean_trust=0.4)},
        {"scenario": "exp2-servo", "controller": "learned", "estimator": "don",
         "mean": figures(rmse_deg=1.25, mean_trust=None)},
        {"scenario": "exp3-forearm-high", "controller": "position", "estimator": "don",
         "mean": figures(rmse_deg=6.0, mean_trust=0.8)},
    ]
    rows = paper_table(results).splitlines()
    assert len(rows) == 2 + 3
    assert rows[2] == ("| exp1 | `exp1-noisy-fast` | don | position | 25.00 | 1.0 | 0.40 | "
                       "DON failed: fast random motion with body sway | "
                       "fails here too (RMSE over 20 deg) |  |")
    assert rows[3] == ("| exp2 | `exp2-servo` | don | learned | 1.25 | 1.0 | - | "
                       "servo arm copied near perfectly | near perfect (RMSE at most 4 deg) |"
                       "  |")
    assert rows[4].endswith("| eta 0.80, outside the paper's 0.3-0.4 |  |")
    assert rows[4].startswith("| exp3 high | `exp3-forearm-high` | don | position | 6.00 |")


def test_every_experiment_runs_with_each_controller_and_exp4_only_with_the_servo() -> None:
    """The learned tracker drives one joint: the multi-link exp4 runs with the position
    controller alone."""
    configs = paper_configs((3, 4), frames=50)
    assert [(c.scenario, c.estimator, c.controller) for c in configs] == [
        (scenario, "don", controller)
        for scenario in ("exp1-noisy-fast", "exp2-servo", "exp3-forearm-none",
                         "exp3-forearm-low", "exp3-forearm-high")
        for controller in ("position", "learned")] + [("exp4-hand", "don", "position")]
    assert {(c.seeds, c.frames) for c in configs} == {((3, 4), 50)}
    learned = paper_configs((7,), controllers=("learned",))
    assert [c.scenario for c in learned] == ["exp1-noisy-fast", "exp2-servo",
                                             "exp3-forearm-none", "exp3-forearm-low",
                                             "exp3-forearm-high"]
    assert {(c.seeds, c.frames) for c in learned} == {((7,), None)}


def test_exp4_has_no_verdict_and_its_note_in_the_table() -> None:
    head, rule, row = paper_table([{"scenario": "exp4-hand", "controller": "position",
                                    "estimator": "don", "mean": figures(3.456, 0.25)}]
                                  ).splitlines()
    assert head == ("| experiment | scenario | estimator | controller | RMSE (deg) | "
                    "lag (frames) | mean eta | paper | here | note |")
    assert rule == "|" + "---|" * 10
    assert row == ("| exp4 | `exp4-hand` | don | position | 3.46 | 1.0 | 0.25 | forearm, thumb, "
                   "index finger tracked | - | DON for several links (LinkedDON); per joint in "
                   "RESULTS.md |")


def test_an_eta_range_verdict_counts_both_ends_inside() -> None:
    """The verdict builder itself, on a range of its own (the experiments' verdicts are
    built when the module loads)."""
    from imimic_gym.paper import _eta_in

    verdict = _eta_in(0.2, 0.6)
    assert verdict(figures(mean_trust=0.2)) == "eta 0.20, inside the paper's 0.2-0.6"
    assert verdict(figures(mean_trust=0.6)) == "eta 0.60, inside the paper's 0.2-0.6"
    assert verdict(figures(mean_trust=0.19)) == "eta 0.19, outside the paper's 0.2-0.6"
    assert verdict(figures(mean_trust=0.61)) == "eta 0.61, outside the paper's 0.2-0.6"


def test_a_learned_controller_first_still_leaves_exp4_its_servo() -> None:
    configs = paper_configs((1,), controllers=("learned", "position"))
    assert [(c.scenario, c.controller) for c in configs][-3:] == [
        ("exp3-forearm-high", "learned"), ("exp3-forearm-high", "position"),
        ("exp4-hand", "position")]
