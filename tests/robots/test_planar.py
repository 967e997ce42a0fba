import math

import mujoco
import numpy as np
import pytest

from imimic_gym.robots.planar import ArmSpec, build_arm_model


def settle(spec: ArmSpec, ctrl: np.ndarray, seconds: float = 1.0) -> mujoco.MjData:
    model = build_arm_model(spec)
    data = mujoco.MjData(model)
    data.ctrl[:] = ctrl
    mujoco.mj_step(model, data, nstep=int(seconds / model.opt.timestep))
    return data


@pytest.mark.parametrize("n", [1, 2, 3])
@pytest.mark.parametrize("control", ["position", "velocity", "torque"])
def test_arm_builds_with_one_actuator_per_joint(n: int, control: str) -> None:
    spec = ArmSpec(link_lengths=(0.3,) * n, link_masses=(0.5,) * n,
                   joint_ranges=((-2.0, 2.0),) * n, control=control)
    model = build_arm_model(spec)
    assert (model.njnt, model.nu) == (n, n)
    assert np.allclose(model.jnt_range, [[-2.0, 2.0]] * n)


def test_default_arm_has_the_papers_120_degree_servo_range() -> None:
    lo, hi = ArmSpec().joint_ranges[0]
    assert math.degrees(hi - lo) == pytest.approx(120.0)


def test_position_servo_reaches_a_commanded_angle_in_the_horizontal_plane() -> None:
    spec = ArmSpec(plane="horizontal")
    data = settle(spec, np.array([0.5]))
    # measured 1e-14 deg off: without gravity the servo settles on the target to float
    # round-off (issue 40: a floor of 1e-6)
    assert math.degrees(data.qpos[0]) == pytest.approx(math.degrees(0.5), abs=1e-6)


def test_gravity_acts_in_the_vertical_plane_only() -> None:
    # An unpowered arm held out sideways: it falls when vertical, stays when horizontal.
    for plane, expect_fall in (("vertical", True), ("horizontal", False)):
        spec = ArmSpec(plane=plane, control="torque", reference_direction=0.0,
                       joint_ranges=((-3.0, 3.0),))
        model = build_arm_model(spec)
        data = mujoco.MjData(model)
        mujoco.mj_step(model, data, nstep=200)
        moved = abs(data.qpos[0]) > 0.1
        assert moved == expect_fall, plane


def test_link_tip_points_along_reference_plus_angle() -> None:
    # Reference pointing down the image, q = +90 degrees (CCW): the link points right.
    spec = ArmSpec(link_lengths=(0.4,), reference_direction=-math.pi / 2,
                   joint_ranges=((-3.0, 3.0),))
    model = build_arm_model(spec)
    data = mujoco.MjData(model)
    data.qpos[0] = math.pi / 2
    mujoco.mj_kinematics(model, data)
    tip = data.geom_xpos[model.geom("link1").id]  # the capsule's centre, half-way out
    base = data.xpos[model.body("link1").id]
    assert np.allclose(tip - base, [0.2, 0.0, 0.0], atol=1e-9)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"link_lengths": (0.1,) * 4, "link_masses": (1,) * 4, "joint_ranges": ((0, 1),) * 4},
         "1 to 3 links, got 4"),
        ({"link_lengths": (0.1, 0.1)}, "one entry per link"),
        ({"link_lengths": (-0.1,)}, "positive metres"),
        ({"joint_ranges": ((1.0, 0.0),)}, "low < high"),
        ({"control": "thrust"}, "control must be one of"),
    ],
)
def test_bad_arm_specs_are_named(kwargs: dict, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        ArmSpec(**kwargs)


def test_a_branching_arm_puts_both_fingers_at_the_end_of_link_one() -> None:
    # The hand: a forearm, and a thumb and an index finger that both start at its end.
    spec = ArmSpec(link_lengths=(0.3, 0.06, 0.08), link_masses=(0.8, 0.05, 0.05),
                   joint_ranges=((-3.0, 3.0),) * 3, parents=(-1, 0, 0))
    model = build_arm_model(spec)
    data = mujoco.MjData(model)
    data.qpos[:] = [0.0, math.pi / 2, -math.pi / 2]
    mujoco.mj_kinematics(model, data)
    wrist = data.xpos[model.body("link1").id] + [0.3, 0.0, 0.0]
    assert np.allclose(data.xpos[model.body("link2").id], wrist)
    assert np.allclose(data.xpos[model.body("link3").id], wrist)
    # Reference along +x (image right): +90 degrees points up the image, -90 down.
    thumb_mid = data.geom_xpos[model.geom("link2").id]
    index_mid = data.geom_xpos[model.geom("link3").id]
    assert np.allclose(thumb_mid - wrist, [0.0, 0.0, 0.03], atol=1e-9)
    assert np.allclose(index_mid - wrist, [0.0, 0.0, -0.04], atol=1e-9)
    assert spec.reach == pytest.approx(0.38)


def test_parents_must_form_a_tree_rooted_at_the_base() -> None:
    with pytest.raises(ValueError, match="parents must give link 0 the base"):
        ArmSpec(link_lengths=(0.3, 0.1), link_masses=(1, 1), joint_ranges=((0, 1),) * 2,
                parents=(0, -1))


@pytest.mark.parametrize("scenario", ["chain-2", "chain-3", "exp4-hand"])
def test_each_joint_holds_its_own_static_load_equally_many_times(scenario: str) -> None:
    """The motor limits against MuJoCo's gravity torques with every link straight out
    horizontally (the base joint keeps the spec's max_torque)."""
    from imimic_gym.clips.scenarios import get_scenario

    spec = get_scenario(scenario).robot_arm("torque")
    model = build_arm_model(spec)
    data = mujoco.MjData(model)
    data.qpos[0] = -spec.reference_direction  # the base link points along image right
    mujoco.mj_forward(model, data)  # at rest, the bias force is gravity alone
    limits = model.actuator_ctrlrange[:, 1]
    assert limits[0] == spec.max_torque
    times_over = limits / np.abs(data.qfrc_bias)
    assert np.allclose(times_over, times_over[0], rtol=1e-6)


def test_a_horizontal_arm_shares_one_torque_limit() -> None:
    spec = ArmSpec(link_lengths=(0.1, 0.1), link_masses=(0.02, 0.02),
                   joint_ranges=((-1, 1),) * 2, plane="horizontal", control="torque",
                   max_torque=0.3)
    assert build_arm_model(spec).actuator_ctrlrange[:, 1].tolist() == [0.3, 0.3]
