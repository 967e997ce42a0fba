"""Files written whole or not at all, with the permissions of any file the user makes."""

import json
import os
import stat
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from imimic_gym.atomic import atomic_write, write_bytes, write_json, write_text


@pytest.fixture
def umask() -> Iterator[None]:
    """Restores the process's umask after a test that sets its own."""
    before = os.umask(0o022)
    try:
        yield
    finally:
        os.umask(before)


def mode(path: Path) -> int:
    return stat.S_IMODE(path.stat().st_mode)


def test_the_file_holds_exactly_what_was_written(tmp_path) -> None:
    write_bytes(tmp_path / "a" / "b.bin", b"\x00\xff raw\n")
    assert (tmp_path / "a" / "b.bin").read_bytes() == b"\x00\xff raw\n"
    write_text(tmp_path / "t.txt", "angle \u03b8\n")
    assert (tmp_path / "t.txt").read_bytes() == "angle \u03b8\n".encode()
    write_json(tmp_path / "m.json", {"rmse_deg": 1.5, "seeds": [1, 2]})
    assert (tmp_path / "m.json").read_text() == (
        '{\n  "rmse_deg": 1.5,\n  "seeds": [\n    1,\n    2\n  ]\n}\n')
    write_json(tmp_path / "flat.json", [1, "x"], indent=None)
    assert (tmp_path / "flat.json").read_text() == '[1, "x"]\n'


def test_a_second_write_replaces_the_first_whole(tmp_path) -> None:
    write_bytes(tmp_path / "f", b"a much longer first version")
    write_bytes(tmp_path / "f", b"short")
    assert (tmp_path / "f").read_bytes() == b"short"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["f"]


@pytest.mark.parametrize(("mask", "expected"), [(0o022, 0o644), (0o002, 0o664),
                                                 (0o077, 0o600), (0o027, 0o640)])
def test_permissions_follow_the_umask(tmp_path, umask, mask: int, expected: int) -> None:
    os.umask(mask)
    write_bytes(tmp_path / "shared.npz", b"x")
    assert oct(mode(tmp_path / "shared.npz")) == oct(expected)


@pytest.mark.parametrize("stop", [KeyboardInterrupt, OSError])
def test_an_interrupted_write_leaves_the_old_file_whole(tmp_path, stop) -> None:
    target = tmp_path / "clip.npz"
    write_bytes(target, b"the old clip, complete")
    with pytest.raises(stop), atomic_write(target) as stream:
        stream.write(b"half of the new")
        raise stop("stopped part-way")
    assert target.read_bytes() == b"the old clip, complete"
    assert [p.name for p in tmp_path.iterdir()] == ["clip.npz"]  # no temporary file left


def test_an_interrupted_first_write_leaves_no_file(tmp_path) -> None:
    with pytest.raises(KeyboardInterrupt), atomic_write(tmp_path / "new.json") as stream:
        stream.write(b"{")
        raise KeyboardInterrupt
    assert list(tmp_path.iterdir()) == []


def test_the_clip_cache_and_pose_labels_are_readable_to_the_group(tmp_path, umask,
                                                                  monkeypatch) -> None:
    """A --cache-dir shared between users: under umask 027 the group can read each file
    (the old mkstemp copies made them 0600)."""
    from imimic_gym.clips.cache import cache_path, load_clip
    from imimic_gym.clips.scenarios import get_scenario
    from imimic_gym.labels import PoseLabels, _write_labels

    os.umask(0o027)
    monkeypatch.setenv("IMIMIC_CACHE_DIR", str(tmp_path))
    spec = get_scenario("exp2-servo", n_frames=3, seed=77)
    load_clip(spec, progress=False)
    assert oct(mode(cache_path(spec))) == oct(0o640)
    labels = PoseLabels(keypoints=np.zeros((2, 3, 2)), confidence=np.ones((2, 3)),
                        labelled=np.ones(2, bool), side=("right", "left"))
    _write_labels(tmp_path / "labels" / "x.npz", labels)
    assert oct(mode(tmp_path / "labels" / "x.npz")) == oct(0o640)
    with np.load(tmp_path / "labels" / "x.npz") as saved:
        assert saved["keypoints"].shape == (2, 3, 2)
        assert saved["side"].tolist() == ["right", "left"]


def test_the_commands_json_is_written_through_the_helper(tmp_path, umask) -> None:
    from imimic_gym.cli.common import save_json

    os.umask(0o002)
    save_json(str(tmp_path / "out" / "results.json"), [{"rmse_deg": 2.0}])
    assert json.loads((tmp_path / "out" / "results.json").read_text()) == [{"rmse_deg": 2.0}]
    assert oct(mode(tmp_path / "out" / "results.json")) == oct(0o664)
