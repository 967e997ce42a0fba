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
