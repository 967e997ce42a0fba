"""Speed measurements behind `imimic bench`. Each speed is reported beside a reference
measured in the same run on the same machine, because absolute times on a shared machine
are noise."""

from __future__ import annotations

import os
import platform
import time
from typing import Any

import gymnasium as gym
import numpy as np

from imimic_gym.clips.cache import load_clip
from imimic_gym.clips.scenarios import get_scenario, scenario_names
from imimic_gym.clips.synthetic import render_clip

__all__ = ["bench_don", "bench_env", "bench_render", "don_window_and_lighting", "machine",
           "per_frame_ms", "run_raw_mog2"]


def machine() -> dict[str, Any]:
    import mujoco

    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as f:
            cpu = next(line.split(":", 1)[1].strip() for line in f if line.startswith("model name"))
    except (OSError, StopIteration):
        pass
    return {
        "cpu": cpu,
        "cores": os.cpu_count(),
        "python": platform.python_version(),
        "mujoco": mujoco.__version__,
        "gymnasium": gym.__version__,
        "numpy": np.__version__,
        "MUJOCO_GL": os.environ.get("MUJOCO_GL"),
    }


def _steps_per_second(env: gym.Env, actions: np.ndarray) -> float:
    env.reset(seed=0)
    start = time.perf_counter()
    for action in actions:
        _, _, terminated, truncated, _ = env.step(action)
        if terminated or truncated:
            env.reset()
    return len(actions) / (time.perf_counter() - start)


def bench_env(steps: int = 3000, repeats: int = 5, seed: int = 0) -> dict[str, Any]:
    """Steps/s of ImitateVideo-v0 (default scenario, clip from the cache, frames in the
    observation, through ``gym.make``'s wrappers) and of Gymnasium's Reacher-v5, with random
    actions, alternating ``repeats`` times; the medians and their ratio."""
    load_clip(get_scenario("default"), progress=False)  # the cache, not rendering, is timed
    imitate = gym.make("ImitateVideo-v0")
    reacher = gym.make("Reacher-v5")
    rng = np.random.default_rng(seed)
    runs: dict[str, list[float]] = {"imitate": [], "reacher": []}
    for _ in range(repeats):
        for name, env in (("imitate", imitate), ("reacher", reacher)):
            assert isinstance(env.action_space, gym.spaces.Box)  # both envs act with a Box
            actions = rng.uniform(-1, 1, size=(steps, *env.action_space.shape)).astype(np.float32)
            runs[name].append(_steps_per_second(env, actions))
    imitate.close()
    reacher.close()
    imitate_sps, reacher_sps = float(np.median(runs["imitate"])), float(np.median(runs["reacher"]))
    return {
        "imitate_steps_per_s": imitate_sps,
        "reacher_steps_per_s": reacher_sps,
        "ratio": imitate_sps / reacher_sps,
        "steps": steps,
        "repeats": repeats,
    }


def _mujoco_renderer_fps(n_frames: int, height: int, width: int) -> float:
    """Frames/s of ``mujoco.Renderer`` drawing plain RGB of the default scenario's scene at
    the same size: the reference that clip rendering is compared with in the same run."""
    import mujoco

    from imimic_gym.clips.demonstrator import scene_mjcf

    spec = get_scenario("default", height=height, width=width)
    model = mujoco.MjModel.from_xml_string(scene_mjcf(spec, np.random.default_rng(0)))
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    renderer = mujoco.Renderer(model, height, width)
    try:
        renderer.update_scene(data, camera="film")
        renderer.render()  # warm-up
        start = time.perf_counter()
        for _ in range(n_frames):
            renderer.update_scene(data, camera="film")
            renderer.render()
        return n_frames / (time.perf_counter() - start)
    finally:
        renderer.close()


def bench_render(n_frames: int = 150, height: int = 240, width: int = 320,
                 repeats: int = 3) -> dict[str, float]:
    """Frames/s of rendering each scenario from scratch (no cache), truth included; and,
    as ``mujoco_renderer_rgb``, of ``mujoco.Renderer`` drawing plain RGB frames of the
    default scene in the same run. Medians of ``repeats`` rounds (this machine is
    shared: one run can be a third slower than the next)."""
    render_clip(get_scenario("default", n_frames=5), progress=False)  # GL warm-up
    runs: dict[str, list[float]] = {name: [] for name in scenario_names()}
    for _ in range(repeats):
        for name in runs:
            spec = get_scenario(name, n_frames=n_frames, height=height, width=width)
            start = time.perf_counter()
            render_clip(spec, progress=False)
            runs[name].append(n_frames / (time.perf_counter() - start))
    # The reference runs after the rounds, so its GL context cannot disturb them.
    runs["mujoco_renderer_rgb"] = [_mujoco_renderer_fps(n_frames, height, width)
                                   for _ in range(repeats)]
    return {name: float(np.median(fps)) for name, fps in runs.items()}


PAPER_RESOLUTIONS = ((240, 320), (480, 640), (720, 960), (960, 1280))


def per_frame_ms(run, frames: np.ndarray) -> float:
    """CPU ms per frame of ``run(frames)``: this process's CPU time, so the time the OS
    gives another job on a shared machine does not count (every run is one thread)."""
    start = time.process_time()
    run(frames)
    return (time.process_time() - start) / len(frames) * 1e3


def run_raw_mog2(frames: np.ndarray) -> None:
    """Raw OpenCV MOG2 (no shadow detection, as the MOG2 estimator uses it): ``apply`` on
    every full frame, with a fresh subtractor; the reference DON's speed is compared with."""
    import cv2

    subtractor = cv2.createBackgroundSubtractorMOG2(detectShadows=False)
    for frame in frames:
        subtractor.apply(frame)


def bench_don(frames: int = 90, repeats: int = 7,
              resolutions=PAPER_RESOLUTIONS) -> dict[str, Any]:
    """Per-frame CPU ms of DON, the MOG2 and CamShift estimators, and raw OpenCV MOG2
    (``apply`` on the full frame, the paper's comparison), on the same rendered frames of
    the default scenario at each resolution; one OpenCV thread; median of alternating
    runs after an untimed warm-up. ``ratio_mog2`` = DON / raw MOG2 (the paper: 30 ms /
    100 ms = 0.3); ``ratio_mog2_paper`` the same for DON with the paper's layers only
    (``appearance=False``)."""
    import cv2

    from imimic_gym.estimators.baselines import CamShiftEstimator, MOG2Estimator
    from imimic_gym.estimators.don.one_link import DON

    cv2.setNumThreads(1)
    runs = {
        "don": lambda f: DON().run(f),
        "don_paper": lambda f: DON(appearance=False).run(f),
        "mog2_estimator": lambda f: MOG2Estimator().run(f),
        "camshift_estimator": lambda f: CamShiftEstimator().run(f),
        "mog2_raw": run_raw_mog2,
    }
    rows = []
    for height, width in resolutions:
        clip = load_clip(get_scenario("default", height=height, width=width, n_frames=frames),
                         progress=False)
        times: dict[str, list[float]] = {name: [] for name in runs}
        for run in runs.values():  # untimed: the first run in a process pays one-time setup
            run(clip.frames)
        for _ in range(repeats):
            for name, run in runs.items():
                times[name].append(per_frame_ms(run, clip.frames))
        row: dict[str, Any] = {"resolution": f"{height}x{width}",
                               **{f"{k}_ms": float(np.median(v)) for k, v in times.items()}}
        row["ratio_mog2"] = row["don_ms"] / row["mog2_raw_ms"]
        row["ratio_mog2_paper"] = row["don_paper_ms"] / row["mog2_raw_ms"]
        rows.append(row)
    return {"frames": frames, "repeats": repeats, "opencv_threads": 1,
            "clock": "process CPU time", "rows": rows}


def don_window_and_lighting(out_prefix: str, frames: int = 90) -> dict[str, Any]:
    """The paper's Fig. 3: DON's time per frame against the window N (3a) and the area it
    detects against light intensity (3b), on the default scenario at 240x320; PNGs saved
    as ``<out_prefix>_window.png`` and ``<out_prefix>_lighting.png``."""
    import cv2
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from imimic_gym.estimators.don.one_link import DON

    cv2.setNumThreads(1)
    clip = load_clip(get_scenario("default", n_frames=frames), progress=False)
    windows = [2, 4, 6, 8, 10, 12, 15, 20]
    window_ms = [float(np.median([per_frame_ms(lambda f, n=n: DON(window=n).run(f),
                                                clip.frames) for _ in range(3)]))
                 for n in windows]
    lighting = [0.2, 0.3, 0.4, 0.5, 0.6, 0.8, 1.0]
    areas = []
    for level in lighting:
        lit = load_clip(get_scenario("default", n_frames=frames, lighting=level), progress=False)
        don = DON()
        total = 0
        for frame in lit.frames:
            don.update(frame)
            total += int(np.count_nonzero(don.last_mask)) if don.last_mask is not None else 0
        areas.append(total / len(lit) * don.scale**2)  # in input pixels per frame
    for name, x, y, labels in (
        ("window", windows, window_ms, ("frames in the input layer, N",
                                        "CPU ms per frame (240x320, 1 thread)",
                                        "DON: computation time vs N (paper Fig. 3a)")),
        ("lighting", lighting, areas, ("light intensity", "moving pixels detected per frame",
                                       "DON: detected area vs light (paper Fig. 3b)")),
    ):
        fig, ax = plt.subplots(figsize=(5, 3.5))
        ax.plot(x, y, "o-")
        ax.set(xlabel=labels[0], ylabel=labels[1], title=labels[2])
        ax.set_ylim(bottom=0)
        ax.grid(alpha=0.3)
        fig.tight_layout()
        fig.savefig(f"{out_prefix}_{name}.png", dpi=110)
        plt.close(fig)
    return {"window": windows, "window_ms": window_ms, "lighting": lighting,
            "area_px_per_frame": areas}
