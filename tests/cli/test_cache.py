"""`imimic cache --warm` on this machine (the Ray backend: tests/test_ray_rendering.py)."""

import numpy as np
import pytest

from imimic_gym.cli import main
from imimic_gym.clips.cache import cache_path, load_clip
from imimic_gym.clips.scenarios import get_scenario

WARM = ["cache", "--warm", "default", "--episodes", "2", "--first-seed", "41", "--frames",
        "6"]


def test_warming_here_renders_each_missing_clip_once_into_the_cache_dir(
        tmp_path, monkeypatch: pytest.MonkeyPatch, capsys) -> None:
    monkeypatch.setenv("IMIMIC_CACHE_DIR", str(tmp_path / "usual"))  # restored afterwards
    shared = tmp_path / "shared"
    assert main([*WARM, "--cache-dir", str(shared)]) == 0
    assert "2 of 2 clips cached and checked here" in capsys.readouterr().out
    specs = [get_scenario("default", n_frames=6).replace(seed=seed) for seed in (41, 42)]
    paths = [cache_path(spec) for spec in specs]
    assert [p.parent for p in paths] == [shared] * 2 and all(p.is_file() for p in paths)
    assert not (tmp_path / "usual").exists()
    for spec in specs:  # the cached clip is the one a fresh render gives
        np.testing.assert_array_equal(load_clip(spec, progress=False).frames,
                                      load_clip(spec, progress=False, use_cache=False).frames)
    # All there: nothing rendered again (a new render would replace the file: a new inode).
    written = [p.stat().st_ino for p in paths]
    assert main([*WARM, "--cache-dir", str(shared)]) == 0
    assert [p.stat().st_ino for p in paths] == written
    assert f"{shared}: 2 clips" in capsys.readouterr().out
