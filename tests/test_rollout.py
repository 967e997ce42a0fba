"""The episode loop's realtime pacing, on a patched clock (no wall-clock time is read)."""

from typing import Any, ClassVar

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
    list(episode(gym.make("ImitateVideo-v0", n_frames=5), hold, seed=0))  # the default
    assert clock.sleeps == []


class ScriptedEnv(gym.Env):
    """A clip of ``len(truth)`` frames at 10 frames/s whose robot goes where it is told:
    frame i's target is ``truth[i]`` (NaN: no label), its occlusion ``occlusion[i]``, the
    reward of reaching frame i is i; the estimate (one joint) carries trust 0.1 * i.
    ``stream_ends_at``: the frame whose step raises `StreamEndedError` instead."""

    metadata: ClassVar[dict[str, Any]] = {"render_fps": 10}

    def __init__(self, truth: list[float], occlusion: list[float],
                 with_estimate: bool = True, stream_ends_at: int | None = None) -> None:
        self.truth, self.occlusion = truth, occlusion
        self.with_estimate, self.stream_ends_at = with_estimate, stream_ends_at
        self.steps: list[np.ndarray] = []
        self.i, self.qpos = 0, np.zeros(1)
        self.reset_with: tuple[int | None, dict[str, Any] | None] | None = None

    def frame(self) -> tuple[dict[str, Any], dict[str, Any]]:
        obs: dict[str, Any] = {"qpos": self.qpos.copy()}
        if self.with_estimate:
            obs["estimate"] = np.array([9.0, 9.0, 9.0, 9.0, 0.1 * self.i, 0.0])
        target = self.truth[self.i]  # NaN: no label (the env still gives a stale target)
        return obs, {"frame_index": self.i,
                     "target_angles": np.array([-1.0 if np.isnan(target) else target]),
                     "occlusion": self.occlusion[self.i], "has_truth": not np.isnan(target)}

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        self.i, self.qpos = 0, np.zeros(1)
        self.reset_with = (seed, options)
        return self.frame()

    def step(self, action: np.ndarray):
        from imimic_gym.clips.video import StreamEndedError

        self.steps.append(np.array(action))
        if self.i + 1 == self.stream_ends_at:
            raise StreamEndedError("the file ended")
        self.i, self.qpos = self.i + 1, np.asarray(action, dtype=np.float64)
        obs, info = self.frame()
        return obs, float(self.i), False, self.i == len(self.truth) - 1, info

    def render(self) -> np.ndarray:
        return np.full((2, 4, 3), self.i, dtype=np.uint8)


class Stepper:
    """A controller that moves the joint 0.1 rad a frame and counts its resets."""

    def __init__(self) -> None:
        self.resets = 0

    def reset(self) -> None:
        self.resets += 1

    def __call__(self, obs: dict[str, Any]) -> np.ndarray:
        return np.asarray(obs["qpos"]) + 0.1


class Watcher:
    def __init__(self) -> None:
        self.seen: list[tuple[int, float]] = []

    def on_step(self, env: gym.Env, step: Any) -> None:
        self.seen.append((step.info["frame_index"], step.reward))


def test_run_episode_logs_every_frame_and_leaves_frames_without_truth_nan() -> None:
    from imimic_gym.rollout import run_episode

    env = ScriptedEnv([0.0, 0.1, np.nan, 0.3], [0.0, 0.5, 0.0, 0.0])
    controller, watcher = Stepper(), Watcher()
    trajectory = run_episode(env, controller, seed=7, record=True, options={"speed": 2},
                             observers=[watcher])
    assert env.reset_with == (7, {"speed": 2})
    np.testing.assert_allclose(trajectory.time, [0.0, 0.1, 0.2, 0.3])
    np.testing.assert_allclose(trajectory.robot[:, 0], [0.0, 0.1, 0.2, 0.3])
    np.testing.assert_array_equal(trajectory.target[:, 0], [0.0, 0.1, np.nan, 0.3])
    np.testing.assert_array_equal(trajectory.has_truth, [True, True, False, True])
    np.testing.assert_array_equal(trajectory.reward, [0.0, 1.0, 2.0, 3.0])
    np.testing.assert_array_equal(trajectory.occlusion, [0.0, 0.5, 0.0, 0.0])
    np.testing.assert_allclose(trajectory.trust, [0.0, 0.1, 0.2, 0.3])
    assert [int(frame[0, 0, 0]) for frame in trajectory.frames] == [0, 1, 2, 3]
    assert watcher.seen == [(0, 0.0), (1, 1.0), (2, 2.0), (3, 3.0)]
    assert controller.resets == 1
    assert len(env.steps) == 3  # the last frame's action is answered, not stepped


def test_without_an_estimate_or_recording_the_trajectory_has_no_trust_or_frames() -> None:
    from imimic_gym.rollout import run_episode

    trajectory = run_episode(ScriptedEnv([0.0, 0.0, 0.0], [0.0] * 3, with_estimate=False),
                             Stepper())
    assert trajectory.trust is None and trajectory.frames == []
    assert trajectory.metrics()["mean_trust"] is None


def test_a_stream_that_ends_early_ends_the_episode_with_the_frames_read() -> None:
    steps = list(episode(ScriptedEnv([0.0] * 6, [0.0] * 6, stream_ends_at=3), Stepper()))
    assert [step.info["frame_index"] for step in steps] == [0, 1, 2]
    np.testing.assert_allclose([step.action[0] for step in steps], [0.1, 0.2, 0.3])


def test_trajectory_metrics_score_only_the_frames_with_truth() -> None:
    from imimic_gym.metrics import jerk_rms, lag_frames, recovery_time_s
    from imimic_gym.rollout import Trajectory

    robot = np.radians([[1.0], [-1.0], [50.0], [3.0], [-3.0], [0.0]])
    target = np.array([[0.0], [0.0], [np.nan], [0.0], [0.0], [0.0]])
    occlusion = np.array([0.0, 0.5, 0.0, 0.0, 0.0, 0.0])
    trajectory = Trajectory(time=np.arange(6) / 20.0, target=target, robot=robot,
                            reward=np.array([0.0, 1.0, 2.0, 3.0, 4.0, 5.0]),
                            occlusion=occlusion, trust=np.array([0.2, 0.4, 0.6, 0.8, 1.0, 1.0]))
    metrics = trajectory.metrics()
    assert metrics["rmse_deg"] == pytest.approx(2.0)  # sqrt(mean(1, 1, 9, 9, 0))
    assert metrics["max_error_deg"] == pytest.approx(3.0)
    assert metrics["lag_frames"] == lag_frames(target, robot)
    assert metrics["jerk_deg_s3"] == pytest.approx(jerk_rms(robot, 20.0), rel=1e-12)
    assert metrics["jerk_deg_s3"] != pytest.approx(jerk_rms(robot, 1.0))
    assert metrics["recovery_s"] == recovery_time_s(robot, target, occlusion, 20.0) == 0.05
    assert metrics["mean_trust"] == pytest.approx(4.0 / 6)
    assert metrics["mean_reward"] == pytest.approx(2.5)
    assert (metrics["frames"], metrics["truth_frames"]) == (6, 5)


def test_a_trajectory_without_truth_has_no_errors_and_one_frame_no_rate() -> None:
    from imimic_gym.rollout import Trajectory

    blind = Trajectory(time=np.arange(3) / 10.0, target=np.full((3, 1), np.nan),
                       robot=np.zeros((3, 1)), reward=np.zeros(0), occlusion=np.zeros(3))
    metrics = blind.metrics()
    assert metrics["rmse_deg"] is None and metrics["max_error_deg"] is None
    assert (metrics["truth_frames"], metrics["mean_reward"]) == (0, 0.0)
    one = Trajectory(time=np.zeros(1), target=np.zeros((1, 1)), robot=np.ones((1, 1)),
                     reward=np.ones(1), occlusion=np.zeros(1))
    assert one.metrics()["rmse_deg"] == pytest.approx(np.degrees(1.0))
    assert one.metrics()["frames"] == 1


def test_a_log_fed_by_hand_keeps_every_frame_with_its_target() -> None:
    """A vector env's loop calls `add` itself: no frames recorded, time in frames (fps 1)
    until told, and a frame whose info has no has_truth counts as truth."""
    from imimic_gym.rollout import Step, TrajectoryLog

    log = TrajectoryLog()
    assert log.record is False
    for i in (3, 4):
        info = {"frame_index": i, "target_angles": np.array([0.1 * i]), "occlusion": 0.0}
        log.add(Step({"qpos": np.array([0.0])}, info, 0.0, np.zeros(1), 0.0))
    trajectory = log.trajectory()
    np.testing.assert_array_equal(trajectory.time, [3.0, 4.0])
    np.testing.assert_allclose(trajectory.target[:, 0], [0.3, 0.4])
    assert trajectory.frames == [] and trajectory.trust is None


def test_the_frame_rate_is_the_step_between_the_first_two_times() -> None:
    """A clip cut from frame 5 on (times 0.5, 0.6, ...) at 10 frames/s: occluded to its
    second frame and never recovered, which counts the rest of the clip at 10 frames/s."""
    from imimic_gym.rollout import Trajectory

    for frames in (2, 5):
        trajectory = Trajectory(time=(5 + np.arange(frames)) / 10.0,
                                target=np.zeros((frames, 1)),
                                robot=np.radians(np.full((frames, 1), 30.0)),
                                reward=np.zeros(frames),
                                occlusion=np.r_[0.5, np.zeros(frames - 1)])
        assert trajectory.metrics()["recovery_s"] == pytest.approx((frames - 1) / 10.0)
