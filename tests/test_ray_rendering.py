"""Rendering fanned out as Ray tasks: the clip cache warmed and checked, the CNN dataset
the same as one rendered here."""

import numpy as np
import pytest

from imimic_gym.cli import main
from imimic_gym.clips.cache import cache_path, check_warmed, load_clip, warm_clip
from imimic_gym.clips.dataset import generate_arms
from imimic_gym.clips.scenarios import get_scenario


def test_warming_on_ray_fills_the_cache_and_each_clip_is_checked(local_ray, capsys) -> None:
    assert main(["cache", "--warm", "default", "--episodes", "2", "--first-seed", "31",
                 "--frames", "12", "--backend", "ray"]) == 0
    assert "2 of 2 clips cached and checked here" in capsys.readouterr().out
    spec = get_scenario("default", n_frames=12).replace(seed=31)
    assert cache_path(spec).is_file()
    np.testing.assert_array_equal(load_clip(spec, use_cache=False).frames,
                                  load_clip(spec).frames)


def test_a_warmed_clip_that_does_not_read_back_is_named(tmp_path) -> None:
    spec = get_scenario("default", n_frames=12).replace(seed=32)
    warmed = warm_clip(spec)
    assert check_warmed(spec, warmed)
    assert not check_warmed(spec, {**warmed, "path": str(tmp_path / "elsewhere.npz")})
    data = bytearray(cache_path(spec).read_bytes())
    data[len(data) // 2: len(data) // 2 + 4096] = bytes(4096)
    cache_path(spec).write_bytes(bytes(data))
    with pytest.raises(ValueError, match=f"{cache_path(spec).name} .*default seed 32"):
        check_warmed(spec, warmed)


def test_the_cnn_dataset_rendered_on_ray_is_the_one_rendered_here(local_ray) -> None:
    here = generate_arms(1, 2, 20_000, 20_000, "arm1/train", progress=False)
    on_ray = generate_arms(1, 2, 20_000, 20_000, "arm1/train", progress=False,
                           backend="ray")
    assert [a.render for a in on_ray] == [a.render for a in here]
    assert [a.file_name for a in on_ray] == [a.file_name for a in here]
    for a, b in zip(on_ray, here, strict=True):
        np.testing.assert_array_equal(a.keypoints, b.keypoints)
