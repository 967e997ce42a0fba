import ast
import inspect
import pickle
import re
import warnings

import cv2
import gymnasium as gym
import mujoco
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env as gym_check_env

import imimic_gym
from imimic_gym.envs.imitate_video import ImitateVideoEnv, SimulationUnstableError
from imimic_gym.envs.imitate_video_3d import ImitateVideo3DEnv
from imimic_gym.kinematics import wrap_angle
from imimic_gym.render import OffscreenRenderer

FAST = {"n_frames": 30}


def make(**kwargs) -> gym.Env:
    return gym.make("ImitateVideo-v0", **{**FAST, **kwargs})


def test_gymnasium_check_env_passes_without_warnings() -> None:
    env = make(render_mode="rgb_array")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        gym_check_env(env.unwrapped)


def test_sb3_check_env_passes_without_warnings() -> None:
    from stable_baselines3.common.env_checker import check_env as sb3_check_env

    env = make(scenario="chain-2")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        sb3_check_env(env.unwrapped, warn=True)


@pytest.mark.parametrize("scenario", imimic_gym.scenario_names())
def test_every_scenario_gives_finite_observations_in_its_space(scenario: str) -> None:
    env = make(scenario=scenario, n_frames=6)
    obs, _ = env.reset(seed=0)
    assert env.observation_space.contains(obs)
    for _ in range(3):
        obs, reward, _terminated, _truncated, _info = env.step(env.action_space.sample())
        assert env.observation_space.contains(obs)
        assert np.isfinite(reward) and all(np.all(np.isfinite(v)) for v in obs.values())


def test_reward_terms_sum_exactly_and_match_the_error() -> None:
    env = make(scenario="chain-2")
    env.reset(seed=3)
    action = np.array([0.3, -0.5], dtype=np.float32)
    obs, reward, _, _, info = env.step(action)
    assert reward == info["reward_tracking"] + info["reward_ctrl"]
    error = wrap_angle(obs["qpos"] - info["target_angles"])
    assert info["reward_tracking"] == pytest.approx(-np.sum(error**2))
    assert info["reward_ctrl"] == pytest.approx(-1e-3 * np.sum(action.astype(np.float64) ** 2))
    assert info["tracking_error_deg"] == pytest.approx(np.degrees(np.sqrt(np.mean(error**2))))
    assert info["frame_index"] == 1


def test_action_maps_to_the_actuator_range() -> None:
    env = make(scenario="exp2-servo").unwrapped
    assert np.degrees(env.action_to_command(np.array([1.0])))[0] == pytest.approx(60.0)
    assert np.degrees(env.action_to_command(np.array([-1.0])))[0] == pytest.approx(-60.0)
    assert env.command_to_action(np.radians([30.0]))[0] == pytest.approx(0.5)


@pytest.mark.parametrize(
    ("action", "message"),
    [(np.array([np.nan]), "action must be finite"),
     (np.array([0.1, 0.2]), r"action must have shape \(1,\), got \(2,\)"),
     (np.array([[0.1]]), r"action must have shape \(1,\), got \(1, 1\)")],
)
def test_bad_actions_raise_and_leave_the_simulation_untouched(action, message) -> None:
    env = make(scenario="exp2-servo")
    env.reset(seed=0)
    env.step(np.array([0.2], dtype=np.float32))
    inner = env.unwrapped
    before = (inner.data.qpos.copy(), inner.data.qvel.copy(), inner.data.time,
              inner.frame_index, inner.data.ctrl.copy())
    with pytest.raises(ValueError, match=message):
        env.step(action)
    after = (inner.data.qpos, inner.data.qvel, inner.data.time, inner.frame_index,
             inner.data.ctrl)
    assert np.array_equal(before[0], after[0]) and np.array_equal(before[1], after[1])
    assert before[2:4] == after[2:4] and np.array_equal(before[4], after[4])


@pytest.mark.parametrize("control", ["position", "velocity", "torque"])
@pytest.mark.parametrize("scenario", imimic_gym.scenario_names())
def test_bang_bang_actions_keep_the_physics_stable(scenario: str, control: str) -> None:
    """Full-scale actions flipping sign every frame (an RL agent exploring) must not drive
    MuJoCo unstable: it would flag bad accelerations and silently reset the arm. (The
    hand's 50 g fingers under the 25 N m of the arm's joints did, within 5 frames.)"""
    env = make(scenario=scenario, control=control, n_frames=40)
    env.reset(seed=0)
    inner = env.unwrapped
    n = env.action_space.shape[0]
    for t in range(39):
        obs, *_ = env.step(np.full(n, 1.0 if t % 2 else -1.0, dtype=np.float32))
    assert inner.data.warning[mujoco.mjtWarning.mjWARN_BADQACC].number == 0
    low, high = inner.model.jnt_range.T
    assert np.all(obs["qpos"] > low - 0.2) and np.all(obs["qpos"] < high + 0.2)


def test_an_unstable_step_raises_instead_of_resetting_the_arm_silently(
        tmp_path, monkeypatch) -> None:
    monkeypatch.chdir(tmp_path)  # MuJoCo writes MUJOCO_LOG.TXT where it runs
    inner = make(scenario="exp4-hand", control="torque").unwrapped
    inner.reset(seed=0)
    # The arm as it was before joints had their own limits: 25 N m on the 50 g fingers too.
    inner.model.actuator_ctrlrange[:] = (-25.0, 25.0)
    inner._ctrl_low, inner._ctrl_high = np.full(3, -25.0), np.full(3, 25.0)
    with pytest.raises(SimulationUnstableError, match=r"unstable in frame \d+ .*torque control"):
        for t in range(20):
            inner.step(np.full(3, 1.0 if t % 2 else -1.0, dtype=np.float32))
    inner.reset(seed=0)  # usable again after reset
    inner.step(np.zeros(3, dtype=np.float32))


@pytest.mark.parametrize(
    ("kwargs", "error", "message"),
    [({"scenario": "nope"}, ValueError, "unknown scenario 'nope'; valid names"),
     ({"n_links": 5}, ValueError, "n_links must be an integer from 1 to 3, got 5"),
     ({"width": 0}, ValueError, "width must be an integer from 1 to 4096, got 0"),
     ({"height": -1}, ValueError, "height must be an integer from 1 to 4096, got -1"),
     ({"width": 100_000}, ValueError, "width must be an integer from 1 to 4096, got 100000"),
     ({"n_links": True}, ValueError, "n_links must be an integer from 1 to 3, got True"),
     ({"n_frames": 1}, ValueError, "n_frames must be an integer of at least 2, got 1"),
     ({"tracking_weight": float("nan")}, ValueError,
      "tracking_weight must be a finite number >= 0, got nan"),
     ({"reset_noise_scale": -0.1}, ValueError, "reset_noise_scale must be a finite number"),
     ({"control": "thrust"}, ValueError, "control must be one of"),
     ({"modality": "infrared"}, ValueError, "modality must be one of"),
     ({"clip": 123}, ValueError, r"clip must be a video file's path or a Clip, got 123"),
     ({"clip": "{video}", "annotations": 5}, ValueError,
      r"annotations must be 'pose' or the path of a labels file \(COCO-keypoints JSON\), "
      r"got 5"),
     ({"clip": "{video}", "annotations": "{folder}"}, ValueError,
      r"annotations must be 'pose' or the path of a labels file .*, got the folder '.*'"),
     ({"clip_seeds": "abc"}, ValueError,
      r"clip_seeds must be a sequence of whole numbers .*, got 'abc'"),
     ({"clip_seeds": 5}, ValueError, r"clip_seeds must be a sequence of whole numbers"),
     ({"clip_seeds": (1.5,)}, ValueError, r"clip_seeds must be .*, got \(1\.5,\)")],
)
def test_bad_arguments_are_named(kwargs, error, message, servo_mp4) -> None:
    named = {"video": str(servo_mp4), "folder": str(servo_mp4.parent)}
    with pytest.raises(error, match=message):
        make(**{k: v.format(**named) if isinstance(v, str) else v for k, v in kwargs.items()})


def test_episode_is_one_clip_and_truncates_at_its_end() -> None:
    env = make()
    env.reset(seed=0)
    steps, truncated = 0, False
    while not truncated:
        _, _, terminated, truncated, info = env.step(env.action_space.sample())
        assert not terminated
        steps += 1
    assert steps == FAST["n_frames"] - 1 and info["frame_index"] == FAST["n_frames"] - 1


def rollout(env: gym.Env, seed: int, n: int = 10) -> tuple[list, list]:
    obs, _ = env.reset(seed=seed)
    rng = np.random.default_rng(0)
    observations, rewards = [obs], []
    for _ in range(n):
        obs, reward, *_ = env.step(rng.uniform(-1, 1, env.action_space.shape).astype(np.float32))
        observations.append(obs)
        rewards.append(reward)
    return observations, rewards


def test_same_seed_gives_the_same_episode() -> None:
    kwargs = {"scenario": "chain-2", "clip_seeds": (0, 1, 2)}
    a_obs, a_rew = rollout(make(**kwargs), seed=7)
    b_obs, b_rew = rollout(make(**kwargs), seed=7)
    assert a_rew == b_rew
    for a, b in zip(a_obs, b_obs, strict=True):
        assert all(np.array_equal(a[k], b[k]) for k in a)
    c_obs, _ = rollout(make(**kwargs), seed=8)
    assert not np.array_equal(a_obs[0]["qpos"], c_obs[0]["qpos"])


def test_clip_seed_can_be_chosen_at_reset() -> None:
    env = make(clip_seeds=(0, 1))
    _, info0 = env.reset(seed=0, options={"clip_seed": 0})
    frame0 = env.unwrapped.clip.truth.angles.copy()
    _, info1 = env.reset(seed=0, options={"clip_seed": 1})
    assert (info0["clip_seed"], info1["clip_seed"]) == (0, 1)
    assert not np.array_equal(frame0, env.unwrapped.clip.truth.angles)


def test_observations_are_copies() -> None:
    env = make()
    obs, _ = env.reset(seed=0)
    obs["qpos"][:] = 99.0
    obs["frame"][:] = 0
    assert not np.any(env.unwrapped.data.qpos == 99.0)
    obs2, *_ = env.step(np.zeros(1, dtype=np.float32))
    assert obs2["frame"].any()


def test_pickles_and_replays_identically() -> None:
    env = make(scenario="exp2-servo")
    clone = pickle.loads(pickle.dumps(env))
    a_obs, a_rew = rollout(env, seed=4)
    b_obs, b_rew = rollout(clone, seed=4)
    assert a_rew == b_rew and np.array_equal(a_obs[-1]["frame"], b_obs[-1]["frame"])


@pytest.mark.parametrize("mode", ["sync", "async"])
def test_vector_envs(mode: str) -> None:
    envs = gym.make_vec("ImitateVideo-v0", num_envs=2, vectorization_mode=mode,
                        scenario="exp2-servo", **FAST)
    obs, _ = envs.reset(seed=[0, 1])
    assert obs["frame"].shape == (2, 240, 320, 3) and obs["qpos"].shape == (2, 1)
    obs, reward, _terminated, _truncated, _info = envs.step(np.zeros((2, 1), dtype=np.float32))
    assert reward.shape == (2,) and np.all(np.isfinite(reward))
    assert np.all(reward <= 0)
    envs.close()


def test_depth_modality_shows_depth_not_colour() -> None:
    rgb, _ = make(scenario="default").reset(seed=0)
    depth, _ = make(scenario="default", modality="depth").reset(seed=0)
    assert depth["frame"].dtype == np.uint8 and depth["frame"].shape == rgb["frame"].shape
    grey = depth["frame"]
    assert np.array_equal(grey[..., 0], grey[..., 1])  # one grey level per pixel
    # The person stands in front of the wall: nearer, so brighter, in the depth image.
    assert grey[120, 90, 0] > grey[20, 300, 0]


def test_width_and_height_resize_the_frames() -> None:
    env = make(width=160, height=120)
    obs, _ = env.reset(seed=0)
    assert obs["frame"].shape == (120, 160, 3)


def test_render_shows_video_and_robot_side_by_side() -> None:
    env = make(scenario="exp2-servo", render_mode="rgb_array")
    obs, _ = env.reset(seed=0)
    image = env.render()
    assert image.shape == (240, 640, 3) and image.dtype == np.uint8
    assert np.array_equal(image[:, :320], obs["frame"])
    assert image[:, 320:].std() > 5  # the robot view is not blank
    env.close()


@pytest.mark.parametrize("env_class", [ImitateVideoEnv, ImitateVideo3DEnv])
def test_arguments_table_matches_the_signature(env_class: type) -> None:
    doc = env_class.__doc__
    table = dict(re.findall(r"^\s*\| `(\w+)` \| `([^`]*)` \|", doc, flags=re.MULTILINE))
    signature = inspect.signature(env_class.__init__).parameters
    params = {k: v.default for k, v in signature.items() if k != "self"}
    assert set(table) == set(params)
    for name, default in params.items():
        assert ast.literal_eval(table[name]) == default, name


def test_a_clip_object_can_be_the_scenario() -> None:
    from imimic_gym.clips import load_clip
    from imimic_gym.clips.scenarios import get_scenario

    clip = load_clip(get_scenario("chain-2", n_frames=8, seed=3), progress=False)
    env = gym.make("ImitateVideo-v0", scenario=clip, width=160, height=120)
    obs, info = env.reset(seed=0)
    assert obs["frame"].shape == (120, 160, 3) and obs["qpos"].shape == (2,)
    assert info["clip_seed"] == 3
    np.testing.assert_array_equal(info["target_angles"], clip.truth.angles[0])
    # Resizing scales the truth keypoints with the frames.
    resized = env.unwrapped.clip.truth.keypoints
    np.testing.assert_allclose(resized, clip.truth.keypoints * 0.5, rtol=1e-6)
    with pytest.raises(ValueError, match="n_links=3 but the clip has 2 links"):
        gym.make("ImitateVideo-v0", scenario=clip, n_links=3)
    with pytest.raises(ValueError,
                       match="give the clip once: clip=a Clip or scenario='chain-3', not both"):
        gym.make("ImitateVideo-v0", scenario="chain-3", clip=clip)


def test_a_clip_without_truth_runs_with_zero_tracking_reward() -> None:
    from imimic_gym.clips import Clip

    clip = Clip(frames=np.zeros((5, 24, 32, 3), dtype=np.uint8), fps=30.0, meta={"source": "x"})
    env = gym.make("ImitateVideo-v0", scenario=clip)
    _, info = env.reset(seed=0)
    assert info["has_truth"] is False and "target_angles" not in info
    _, reward, _, _, info = env.step(np.array([0.5], dtype=np.float32))
    assert info["reward_tracking"] == 0.0 and reward == info["reward_ctrl"] < 0


def test_only_a_few_clips_stay_in_memory() -> None:
    from imimic_gym.envs.imitate_video import CLIPS_IN_MEMORY

    env = make(scenario="exp2-servo", n_frames=4, clip_seeds=tuple(range(CLIPS_IN_MEMORY + 2)))
    for seed in range(CLIPS_IN_MEMORY + 2):
        env.reset(seed=0, options={"clip_seed": seed})
    assert len(env.unwrapped._clips) == CLIPS_IN_MEMORY
    assert env.unwrapped.clip.meta["seed"] == CLIPS_IN_MEMORY + 1


def test_render_height_draws_a_smaller_picture() -> None:
    env = gym.make("ImitateVideo-v0", scenario="default", n_frames=5, render_mode="rgb_array",
                   render_height=120)
    obs, _ = env.reset(seed=0)
    picture = env.render()
    assert picture.shape == (120, 320, 3) and picture.dtype == np.uint8
    # The frame area-averaged down beside the robot drawn at that size.
    np.testing.assert_array_equal(
        picture[:, :160], cv2.resize(obs["frame"], (160, 120), interpolation=cv2.INTER_AREA))
    inner = env.unwrapped
    with OffscreenRenderer(inner.model, 120, 160) as renderer:
        robot, _ = renderer.render(inner.data, inner.model.camera("robot").id)
    np.testing.assert_array_equal(picture[:, 160:], robot)
    assert robot.std() > 5 and env.render() is not picture  # a new picture each call
    full = gym.make("ImitateVideo-v0", scenario="default", n_frames=5, render_mode="rgb_array",
                    render_height=480)  # taller than the clip: the clip's own size
    full.reset(seed=0)
    assert full.render().shape == (240, 640, 3)
    with pytest.raises(ValueError, match="render_height must be an integer from 1 to 4096"):
        gym.make("ImitateVideo-v0", scenario="default", render_height=0)
    env.close()
    full.close()


def test_a_numpy_integer_is_a_number_of_links() -> None:
    env = make(scenario="chain-2", n_links=np.int64(2), n_frames=4)
    assert env.action_space.shape == (2,)
    env.close()


def test_a_clip_too_short_or_too_slow_to_step_is_refused() -> None:
    from imimic_gym.clips.types import Clip

    frames = np.zeros((1, 24, 32, 3), np.uint8)
    with pytest.raises(ValueError, match="has 1 frame; an episode needs at least 2"):
        make(scenario=Clip(frames=frames, fps=30.0))
    slow = Clip(frames=np.zeros((3, 24, 32, 3), np.uint8), fps=0.002)
    with pytest.raises(ValueError, match=r"plays at 0\.002 frames/s"):
        make(scenario=slow)
