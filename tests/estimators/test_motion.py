"""The path estimator's correction of its newest location, and the torque model."""

import mujoco
import numpy as np
import pytest

from imimic_gym.estimators.motion import PathEstimator, TorqueModel
from imimic_gym.robots.planar import ArmSpec


def test_a_corrected_location_recomputes_its_velocity_and_acceleration() -> None:
    path = PathEstimator(1, fps=10.0)
    for location in (0.0, 0.1, 0.25):
        path.update(np.array([location]))
    v, a = path.correct(np.array([0.3]))
    assert v[0] == pytest.approx(0.2) and a[0] == pytest.approx(0.1)
    assert list(path.V)[-1][0] == pytest.approx(0.2) and len(path.V) == 3
    assert path.location[0] == pytest.approx(0.3)
    assert path.omega()[0] == pytest.approx((0.2 + 0.1) / 2 * 10.0)


def test_correcting_the_first_location_after_a_reset_gives_no_velocity() -> None:
    path = PathEstimator(1, fps=10.0)
    path.update(np.array([1.0]))
    path.reset()
    path.update(np.array([2.0]))
    v, a = path.correct(np.array([2.5]))
    assert v[0] == 0.0 and a[0] == 0.0 and path.location[0] == 2.5


def test_a_location_of_the_wrong_length_is_refused() -> None:
    path = PathEstimator(2, fps=10.0)
    with pytest.raises(ValueError, match="tracks 2 angles, got 1"):
        path.update(np.array([0.1]))


def _inverse_dynamics(model: mujoco.MjModel, angles: np.ndarray, omega: np.ndarray,
                      alpha: np.ndarray) -> np.ndarray:
    data = mujoco.MjData(model)
    data.qpos[:], data.qvel[:], data.qacc[:] = angles, omega, alpha
    mujoco.mj_inverse(model, data)
    return data.qfrc_inverse.copy()


@pytest.mark.parametrize("plane", ["vertical", "horizontal"])
def test_one_link_torque_is_the_inertial_part_of_the_inverse_dynamics(plane: str) -> None:
    """The paper's tau = I alpha: what MuJoCo's inverse dynamics adds for this acceleration
    at the same angle and velocity (gravity and damping cancel in the difference)."""
    model = ArmSpec(plane=plane, control="torque").build_model()
    torque = TorqueModel(model)
    angles, omega = np.array([0.4]), np.array([1.5])
    for alpha in (np.array([4.0]), np.array([-7.0])):
        inertial = (_inverse_dynamics(model, angles, omega, alpha)
                    - _inverse_dynamics(model, angles, omega, np.zeros(1)))
        np.testing.assert_allclose(torque(angles, omega, alpha), inertial, rtol=1e-9)


def test_two_link_torque_produces_the_acceleration_it_was_asked_for() -> None:
    """Forward dynamics with the torque applied (motors off) accelerates the arm at alpha,
    and the torque matches MuJoCo's inverse dynamics."""
    spec = ArmSpec(link_lengths=(0.3, 0.25), link_masses=(0.5, 0.4),
                   joint_ranges=((-2.0, 2.0),) * 2, control="torque")
    model = spec.build_model()
    angles, omega, alpha = np.array([0.3, -0.6]), np.array([1.2, -0.8]), np.array([5.0, -3.0])
    torque = TorqueModel(model)(angles, omega, alpha)
    np.testing.assert_allclose(torque, _inverse_dynamics(model, angles, omega, alpha),
                               rtol=1e-9)
    data = mujoco.MjData(model)
    data.qpos[:], data.qvel[:], data.qfrc_applied[:] = angles, omega, torque
    mujoco.mj_forward(model, data)
    np.testing.assert_allclose(data.qacc, alpha, atol=1e-6)
