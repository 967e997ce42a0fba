import pytest

from imimic_gym.clips.scenarios import (
    SCENARIOS,
    Appearance,
    ClipSpec,
    get_scenario,
    scenario_names,
)

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
     ("background", "space", "background must be one of"),
     ("seed", -1, "seed must be a whole number >= 0 .*, got -1"),
     ("seed", 1.5, "seed must be a whole number >= 0 .*, got 1.5")],
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


# Computed on main before `ClipSpec.appearance` existed: the shipped dataset's records,
# the clip cache and every published figure name clips by these keys.
KEYS_BEFORE_APPEARANCE = {
    "chain-2": "9fea367314566c045571", "chain-3": "b9808869be1f4f775bc3",
    "default": "5c553e28eca78dff5204", "exp1-noisy-fast": "ccc8986d3edb67954636",
    "exp2-servo": "530503d78abf7999239d", "exp3-forearm-high": "5c34afe2810c50f3f783",
    "exp3-forearm-low": "0b2580940b7a4ab0c4a9", "exp3-forearm-none": "e2111501a680a21afd83",
    "exp4-hand": "92720837a1ef3e584e43",
}


def test_existing_scenarios_keep_their_keys() -> None:
    # (The spatial scenarios came later, with keys of their own.)
    keys = {name: SCENARIOS[name].key() for name in KEYS_BEFORE_APPEARANCE}
    assert keys == KEYS_BEFORE_APPEARANCE
    assert "appearance" not in get_scenario("default").record()


def test_a_spec_with_an_appearance_reads_back_from_json() -> None:
    import json

    spec = ClipSpec(seed=4, appearance=Appearance(shirt=(0.1, 0.2, 0.3), camera_tilt=12.5,
                                                  long_sleeves=True))
    again = ClipSpec(**json.loads(json.dumps(spec.record())))
    assert again == spec and again.key() == spec.key()
    assert again.appearance.shirt == (0.1, 0.2, 0.3)  # tuples again, not JSON's lists
    assert spec.key() != spec.replace(appearance=None).key()
    assert spec.key() != spec.replace(appearance=Appearance()).key()


@pytest.mark.parametrize(
    ("changes", "message"),
    [({"skin": (1.2, 0.5, 0.5)}, r"appearance skin must be RGB in \[0, 1\]"),
     ({"wall": (0.5, 0.5)}, "appearance wall must be 3 finite numbers"),
     ({"light_direction": (0, 0, 0)}, "light_direction must not be zero"),
     ({"clutter": -1}, "appearance clutter must be 0 to 100 shapes, got -1"),
     ({"fovy": 5.0}, "appearance fovy must be 10-120 degrees, got 5.0"),
     ({"camera_tilt": 80.0}, r"camera_tilt must be -60..60 degrees, got 80.0")],
)
def test_bad_appearance_values_are_named(changes: dict, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        Appearance(**changes)


def test_the_servo_has_no_appearance() -> None:
    with pytest.raises(ValueError, match="the servo demonstrator has none"):
        get_scenario("exp2-servo", appearance=Appearance())
