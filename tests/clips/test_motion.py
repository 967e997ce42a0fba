import numpy as np
import pytest

from imimic_gym.clips.motion import MOTION_PROFILES, sample_motion

RANGES = np.array([[0.0, 2.0], [-1.0, 1.0]])


@pytest.mark.parametrize("profile", MOTION_PROFILES)
def test_profile_stays_inside_its_ranges_with_margin(profile: str) -> None:
    angle, _, _ = sample_motion(profile, RANGES, 300, 30.0, np.random.default_rng(1))
    width = RANGES[:, 1] - RANGES[:, 0]
    assert np.all(angle >= RANGES[:, 0] + 0.08 * width - 1e-9)
    assert np.all(angle <= RANGES[:, 1] - 0.08 * width + 1e-9)


@pytest.mark.parametrize("profile", MOTION_PROFILES)
def test_velocity_and_acceleration_are_the_derivatives(profile: str) -> None:
    # Integrate each derivative over one fine step (trapezoid rule) and compare with the
    # change of the quantity itself; exact up to O(h^3), and robust to the jerk's jumps.
    fps = 3000.0
    angle, velocity, acceleration = sample_motion(profile, RANGES, 12000, fps,
                                                  np.random.default_rng(2))
    h = 1.0 / fps
    angle_step = np.diff(angle, axis=0) - h * (velocity[1:] + velocity[:-1]) / 2
    velocity_step = np.diff(velocity, axis=0) - h * (acceleration[1:] + acceleration[:-1]) / 2
    assert np.max(np.abs(angle_step)) < 1e-6 * np.max(np.abs(angle)) + 1e-9
    assert np.max(np.abs(velocity_step)) < 1e-4 * np.max(np.abs(velocity))


def test_fast_profile_is_faster_than_spline() -> None:
    rng = np.random.default_rng
    _, v_spline, _ = sample_motion("spline", RANGES, 300, 30.0, rng(3))
    _, v_fast, _ = sample_motion("fast", RANGES, 300, 30.0, rng(3))
    assert np.mean(np.abs(v_fast)) > 2.5 * np.mean(np.abs(v_spline))


def test_unknown_profile_is_named() -> None:
    with pytest.raises(ValueError, match="unknown motion profile 'jitter'"):
        sample_motion("jitter", RANGES, 10, 30.0, np.random.default_rng(0))  # type: ignore[arg-type]
