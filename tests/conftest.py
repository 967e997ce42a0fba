"""Test session setup: a private clip cache, so tests never read a stale user cache and a
fresh CI run renders (and so tests) the real rendering path."""

import os
import shutil
from collections.abc import Iterator

import pytest

os.environ.setdefault("MUJOCO_GL", "egl")


@pytest.fixture(scope="session", autouse=True)
def private_clip_cache(tmp_path_factory: pytest.TempPathFactory) -> Iterator[None]:
    """A clip cache for this session only, deleted when the session ends: a full run renders
    about 3.6 GB of clips, and pytest keeps its last three runs' folders."""
    cache = tmp_path_factory.mktemp("clip_cache")
    os.environ["IMIMIC_CACHE_DIR"] = str(cache)
    yield
    shutil.rmtree(cache, ignore_errors=True)


@pytest.fixture(scope="session")
def servo_clip():
    """The paper's servo scenario, 90 frames (3 s): DON tracks it to about a degree."""
    from imimic_gym.clips.cache import load_clip
    from imimic_gym.clips.scenarios import get_scenario

    return load_clip(get_scenario("exp2-servo", n_frames=90), progress=False)


@pytest.fixture(scope="session")
def servo_mp4(servo_clip, tmp_path_factory: pytest.TempPathFactory):
    """``servo_clip`` recorded to an mp4 with OpenCV (mp4v, lossy)."""
    from imimic_gym.clips.video_writer import write_video

    return write_video(tmp_path_factory.mktemp("video") / "servo.mp4", servo_clip.frames,
                       servo_clip.fps)


@pytest.fixture(scope="session")
def truncated_avi(tmp_path_factory: pytest.TempPathFactory):
    """An MJPEG AVI cut in half: its header still promises 30 frames (64x48 noise, so each
    frame is about the same size), the file holds about 14 that decode."""
    import cv2
    import numpy as np

    folder = tmp_path_factory.mktemp("truncated")
    writer = cv2.VideoWriter(str(folder / "whole.avi"), cv2.VideoWriter_fourcc(*"MJPG"), 30,
                             (64, 48))
    noise = np.random.default_rng(0)
    for _ in range(30):
        writer.write(noise.integers(0, 256, (48, 64, 3), dtype=np.uint8))
    writer.release()
    data = (folder / "whole.avi").read_bytes()
    (folder / "cut.avi").write_bytes(data[:len(data) // 2])
    return folder / "cut.avi"


@pytest.fixture(scope="session")
def edit_listed_mp4(servo_clip, tmp_path_factory: pytest.TempPathFactory):
    """An intact H.264 mp4 whose container reports 30 frames and decodes 24, as phone
    videos trimmed without re-encoding do: 30 frames of the servo clip in one group of
    pictures, cut at 0.2 s by stream copy, so the mp4 keeps every packet from the key
    frame and an edit list that starts the video 6 frames in (made with imageio-ffmpeg's
    ffmpeg)."""
    import subprocess

    import imageio_ffmpeg

    from imimic_gym.clips.video_writer import write_video

    folder = tmp_path_factory.mktemp("edit_list")
    whole = write_video(folder / "whole.mp4", servo_clip.frames[:30], 30.0)
    keyframe_once = folder / "one_gop.mp4"
    ffmpeg = [imageio_ffmpeg.get_ffmpeg_exe(), "-nostdin", "-v", "error", "-y"]
    subprocess.run([*ffmpeg, "-i", str(whole), "-c:v", "libx264", "-g", "300",
                    "-pix_fmt", "yuv420p", str(keyframe_once)], check=True, timeout=120)
    subprocess.run([*ffmpeg, "-ss", "0.2", "-i", str(keyframe_once), "-c", "copy",
                    str(folder / "trimmed.mp4")], check=True, timeout=120)
    return folder / "trimmed.mp4"


@pytest.fixture(scope="module")
def local_ray():
    """A real Ray on this machine (the ray extra; make setup installs it): 2 CPUs, no
    dashboard. The code under test joins it rather than starting its own."""
    import ray

    # address="local": a new Ray of its own, even where `ray start` runs one on this machine
    ray.init(address="local", num_cpus=2, include_dashboard=False, log_to_driver=False)
    yield ray
    ray.shutdown()


@pytest.fixture(scope="session")
def person_mp4(tmp_path_factory: pytest.TempPathFactory):
    """The rendered person (default scenario, seed 5, 20 frames) as an mp4."""
    from imimic_gym.clips.cache import load_clip
    from imimic_gym.clips.scenarios import get_scenario
    from imimic_gym.clips.video_writer import write_video

    clip = load_clip(get_scenario("default", seed=5, n_frames=20), progress=False)
    path = tmp_path_factory.mktemp("person") / "person.mp4"
    write_video(path, clip.frames, clip.fps)
    return path
