import os

import numpy as np
import pytest

from imimic_gym.clips import cache
from imimic_gym.clips.scenarios import get_scenario

SPEC = get_scenario("exp2-servo", n_frames=6, seed=11)


@pytest.fixture
def counted_renders(monkeypatch: pytest.MonkeyPatch) -> list:
    calls: list = []
    real = cache.render_clip

    def counting(spec, progress=True):
        calls.append(spec)
        return real(spec, progress=progress)

    monkeypatch.setattr(cache, "render_clip", counting)
    return calls


def test_second_load_costs_no_rendering_and_is_identical(counted_renders: list) -> None:
    spec = SPEC.replace(seed=21)
    first = cache.load_clip(spec, progress=False)
    second = cache.load_clip(spec, progress=False)
    assert len(counted_renders) == 1
    assert np.array_equal(first.frames, second.frames)
    assert np.array_equal(first.depth, second.depth)
    assert np.array_equal(first.truth.angles, second.truth.angles)
    assert first.truth.keypoint_names == second.truth.keypoint_names


def test_cache_dir_follows_the_environment(monkeypatch: pytest.MonkeyPatch, tmp_path) -> None:
    monkeypatch.setenv("IMIMIC_CACHE_DIR", str(tmp_path / "elsewhere"))
    assert cache.cache_path(SPEC).parent == tmp_path / "elsewhere"


@pytest.mark.parametrize("damage", ["truncate", "flip", "garbage"])
def test_damaged_cache_file_is_rendered_again(damage: str, counted_renders: list,
                                              caplog: pytest.LogCaptureFixture) -> None:
    spec = SPEC.replace(seed=30 + ["truncate", "flip", "garbage"].index(damage))
    good = cache.load_clip(spec, progress=False)
    path = cache.cache_path(spec)
    raw = bytearray(path.read_bytes())
    if damage == "truncate":
        raw = raw[: len(raw) // 2]
    elif damage == "flip":
        middle = len(raw) // 2
        raw[middle : middle + 64] = bytes(b ^ 0xFF for b in raw[middle : middle + 64])
    else:
        raw = bytearray(b"not a clip")
    path.write_bytes(bytes(raw))
    again = cache.load_clip(spec, progress=False)
    assert len(counted_renders) == 2
    assert "unusable" in caplog.text and str(path) in caplog.text
    assert np.array_equal(good.frames, again.frames)
    assert cache.load_clip(spec, progress=False) is not None and len(counted_renders) == 2


def _cached(seeds: range) -> list:
    """Load (render and cache) one tiny clip per seed, each used a second after the last."""
    paths = []
    for k, seed in enumerate(seeds):
        spec = SPEC.replace(seed=seed)
        cache.load_clip(spec, progress=False)
        path = cache.cache_path(spec)
        os.utime(path, (1000.0 + k, 1000.0 + k))  # file times, not a stopwatch: a fixed order
        paths.append(path)
    return paths


def test_the_cache_keeps_the_most_recently_used_clips_within_its_bound(
        monkeypatch: pytest.MonkeyPatch, tmp_path, counted_renders: list) -> None:
    monkeypatch.setenv("IMIMIC_CACHE_DIR", str(tmp_path / "bounded"))
    monkeypatch.setenv("IMIMIC_CACHE_MAX_GB", "inf")
    first, second, third = _cached(range(40, 43))
    size = first.stat().st_size
    # Reading the first clip makes it the most recently used.
    cache.load_clip(SPEC.replace(seed=40), progress=False)
    assert len(counted_renders) == 3
    # Room for three clips (they are the same size to within a few bytes): a fourth
    # pushes out the least recently used, which is now the second.
    monkeypatch.setenv("IMIMIC_CACHE_MAX_GB", str(3.5 * size / 1e9))
    cache.load_clip(SPEC.replace(seed=43), progress=False)
    assert [p.exists() for p in (first, second, third)] == [True, False, True]
    assert cache.cache_usage().clips == 3
    assert cache.cache_usage().bytes <= 3.5 * size
    cache.load_clip(SPEC.replace(seed=41), progress=False)  # gone, so rendered again
    assert len(counted_renders) == 5


def test_a_bound_smaller_than_one_clip_still_keeps_the_clip_just_written(
        monkeypatch: pytest.MonkeyPatch, tmp_path) -> None:
    monkeypatch.setenv("IMIMIC_CACHE_DIR", str(tmp_path / "tiny"))
    monkeypatch.setenv("IMIMIC_CACHE_MAX_GB", "1e-9")  # one byte
    _cached(range(50, 52))
    assert cache.cache_usage().clips == 1
    assert cache.cache_path(SPEC.replace(seed=51)).exists()
    labels = tmp_path / "tiny" / "pose-labels" / "0123.npz"  # a video's pose labels
    labels.parent.mkdir()
    labels.write_bytes(b"labels")
    assert cache.cache_usage().clips == 1  # labels are no clip
    assert cache.clear_cache() == 1 and cache.cache_usage().clips == 0
    assert not labels.exists()


@pytest.mark.parametrize("setting", ["0", "-3", "many", "nan"])
def test_a_bad_cache_bound_is_refused_before_rendering(
        monkeypatch: pytest.MonkeyPatch, tmp_path, counted_renders: list, setting: str) -> None:
    monkeypatch.setenv("IMIMIC_CACHE_DIR", str(tmp_path / "bad"))
    monkeypatch.setenv("IMIMIC_CACHE_MAX_GB", setting)
    with pytest.raises(ValueError, match=f"IMIMIC_CACHE_MAX_GB.*{setting!r}"):
        cache.load_clip(SPEC.replace(seed=60), progress=False)
    assert counted_renders == []


def test_an_async_vector_env_with_an_empty_cache_does_not_hang(tmp_path) -> None:
    """gym.make_vec's async workers fork; a forked worker that renders with EGL hung for
    good. They now render in a new process. Run in a subprocess with a timeout, so a
    regression fails instead of hanging the suite."""
    import os
    import subprocess
    import sys

    script = (
        "import gymnasium as gym, imimic_gym\n"
        "vec = gym.make_vec('ImitateVideo-v0', num_envs=2, vectorization_mode='async',\n"
        "                   n_frames=12, clip_seeds=(3, 4))\n"
        "obs, info = vec.reset(seed=0)\n"
        "print('reset', obs['frame'].shape, sorted(set(info['clip_seed'].tolist())))\n"
        "vec.close()\n")
    env = {**os.environ, "IMIMIC_CACHE_DIR": str(tmp_path / "empty_cache"), "MUJOCO_GL": "egl"}
    done = subprocess.run([sys.executable, "-c", script], env=env, capture_output=True,
                          text=True, timeout=180)
    assert done.returncode == 0, done.stderr[-2000:]
    assert "reset (2, 240, 320, 3)" in done.stdout
    assert len(list((tmp_path / "empty_cache").glob("*"))) >= 1  # rendered into the cache


def test_a_clip_is_filed_under_its_spec_and_its_renderer() -> None:
    """The file's name carries the renderer's fingerprint (8 hex digits), so a checkout
    that draws clips differently files them under other names."""
    name = cache.cache_path(SPEC).name
    assert name == f"{SPEC.key()}-{cache.renderer_fingerprint()}.npz"
    assert len(cache.renderer_fingerprint()) == 8
    int(cache.renderer_fingerprint(), 16)


def test_the_renderer_fingerprint_reads_every_module_that_draws_a_clip() -> None:
    """Every module of ours that rendering a clip imports (in a fresh interpreter) is in
    `RENDERER_MODULES`, but for those that cannot change a clip's pixels or truth."""
    import subprocess
    import sys

    listing = subprocess.run(
        [sys.executable, "-c", "import sys, imimic_gym.clips.synthetic; "
         "print(' '.join(m for m in sys.modules if m.startswith('imimic_gym')))"],
        capture_output=True, text=True, timeout=120, check=True).stdout.split()
    packages = {m for m in listing if (sys.modules.get(m) is not None
                                       and hasattr(sys.modules[m], "__path__"))}
    not_drawing = {"imimic_gym._gl", "imimic_gym._quiet_start", "imimic_gym.atomic",
                   "imimic_gym.clips.cache", "imimic_gym.clips.video",
                   "imimic_gym.clips.video_load", "imimic_gym.robots.so101",
                   "imimic_gym.robots.spec", "imimic_gym.spatial.arm_pose"}
    assert set(listing) - packages - not_drawing <= set(cache.RENDERER_MODULES)
    assert "imimic_gym.clips.synthetic" in listing
