import pytest

from imimic_gym.clips.scenarios import SCENARIOS, ClipSpec, get_scenario, scenario_names

PAPER = ["exp1-noisy-fast", "exp2-servo", "exp3-forearm-none", "exp3-forearm-low",
         "exp3-forearm-high", "default"]


def test_paper_scenarios_exist() -> None:
    assert set(PAPER) <= set(scenario_names())


def test_unknown_scenario_lists_the_valid_names() -> None:
    with pytest.raises(ValueError, match=r"unknown scenario 'exp9'; valid names: .*exp2-servo"):
        get_scenario("exp9")


def test_overrides_change_the_key_but_the_name_does_not() -> None:
    base = get_scenario("default")
    assert base.replace(seed=1).key() != base.key()
    assert base.replace(name="other").key() == base.key()


@pytest.mark.parametrize(
    ("field", "value", "message"),
    [("n_links", 4, "n_links must be an integer from 1 to 3, got 4"),
     ("lighting", 0.1, r"lighting must be in \[0.2, 1.0\], got 0.1"),
     ("width", 0, "width must be a positive integer, got 0"),
     ("height", -5, "height must be a positive integer, got -5"),
     ("occluder", "total", "occluder must be one of"),
     ("background", "space", "background must be one of")],
)
def test_bad_spec_values_are_named(field: str, value: object, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        ClipSpec(**{field: value})


@pytest.mark.parametrize("name", sorted(SCENARIOS))
def test_robot_arm_matches_the_demonstrator(name: str) -> None:
    spec = SCENARIOS[name]
    arm = spec.robot_arm("position")
    assert arm.n_links == spec.n_links
    assert arm.joint_ranges == spec.joint_ranges
    assert arm.reference_direction == spec.reference_direction
