"""The episode loop's realtime pacing, on a patched clock (no wall-clock time is read)."""

from typing import Any

import gymnasium as gym
import numpy as np
import pytest

import imimic_gym.rollout
from imimic_gym.rollout import episode
from tests.clock import FakeClock


@pytest.fixture
def clock(monkeypatch: pytest.MonkeyPatch) -> FakeClock:
    fake = FakeClock()
    monkeypatch.setattr(imimic_gym.rollout, "time", fake)
    return fake


def asked_times(env: gym.Env, controller: Any, realtime: bool) -> list[float]:
    return [step.asked for step in episode(env, controller, seed=0, realtime=realtime)]


def hold(obs: dict[str, Any]) -> np.ndarray:
    return np.asarray(obs["qpos"], dtype=np.float32)


def test_realtime_asks_for_frame_i_at_i_over_fps_after_the_first(clock: FakeClock) -> None:
    env = gym.make("ImitateVideo-v0", n_frames=8)
    fps = float(env.metadata["render_fps"])
    start = clock.now
    asked = asked_times(env, hold, realtime=True)
    assert len(asked) == 8
    np.testing.assert_allclose(np.array(asked[1:]) - start, np.arange(1, 8) / fps, atol=1e-9)
    np.testing.assert_allclose(clock.sleeps, [1 / fps] * 7, atol=1e-9)


def test_realtime_waits_only_for_what_the_frame_has_left(clock: FakeClock) -> None:
    """A controller that takes 40% of a frame: the loop sleeps the other 60%."""
    env = gym.make("ImitateVideo-v0", n_frames=6)
    fps = float(env.metadata["render_fps"])

    def slow(obs: dict[str, Any]) -> np.ndarray:
        clock.spend(0.4 / fps)
        return hold(obs)

    asked = asked_times(env, slow, realtime=True)
    np.testing.assert_allclose(np.diff(asked[1:]), [1 / fps] * 4, atol=1e-9)
    np.testing.assert_allclose(clock.sleeps, [0.6 / fps] * 5, atol=1e-9)


def test_realtime_never_sleeps_behind_schedule(clock: FakeClock) -> None:
    """A controller slower than the frame rate: no waiting (sleeps of 0), frames as fast
    as it answers."""
    env = gym.make("ImitateVideo-v0", n_frames=5)
    fps = float(env.metadata["render_fps"])

    def slower(obs: dict[str, Any]) -> np.ndarray:
        clock.spend(2.5 / fps)
        return hold(obs)

    asked_times(env, slower, realtime=True)
    assert clock.sleeps == [0.0] * 4


def test_without_realtime_the_loop_never_sleeps(clock: FakeClock) -> None:
    asked = asked_times(gym.make("ImitateVideo-v0", n_frames=5), hold, realtime=False)
    assert clock.sleeps == [] and asked == [100.0] * 5
