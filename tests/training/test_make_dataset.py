"""The dataset script, run as a user runs it, on one clip."""

import hashlib
import importlib.util
import subprocess
import sys
from pathlib import Path

import pytest

from imimic_gym.clips.annotations import read_annotations, write_annotations
from imimic_gym.clips.dataset import DEFAULT_ANNOTATIONS

from . import option_helps, refused

SCRIPT = Path(__file__).resolve().parents[2] / "training" / "make_dataset.py"


def shipped_digests() -> dict[str, str]:
    return {path.name: hashlib.sha256(path.read_bytes()).hexdigest()
            for path in sorted(DEFAULT_ANNOTATIONS.glob("*.json"))}


def test_a_default_run_writes_in_the_working_directory_not_over_the_shipped_dataset(
        tmp_path: Path) -> None:
    before = shipped_digests()
    done = subprocess.run([sys.executable, str(SCRIPT), "--train-clips", "1", "--test-clips",
                           "0"], cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-3000:]
    written = tmp_path / "runs" / "data" / "arm1_train.json"
    assert len(read_annotations(written)) == 4
    assert not (tmp_path / "runs" / "data" / "arm1_test.json").exists()
    assert shipped_digests() == before and len(before) == 4


def test_an_out_naming_the_package_folder_says_it_replaces_the_shipped_file(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]) -> None:
    """The real main, with the package's folder moved to a copy of its own."""
    spec = importlib.util.spec_from_file_location("make_dataset", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    package = tmp_path / "imimic_gym" / "data" / "annotations"
    write_annotations(package / "arm1_train.json",
                      read_annotations(DEFAULT_ANNOTATIONS / "arm1_train.json")[:8])
    monkeypatch.setattr(module, "DEFAULT_ANNOTATIONS", package)
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(sys, "argv", ["make_dataset.py", "--train-clips", "1", "--test-clips",
                                      "1", "--out", "imimic_gym/data/annotations"])
    module.main()
    said = capsys.readouterr().out
    assert "package's own dataset folder" in said
    assert "arm1_train.json (replaces the shipped one)" in said
    assert "arm1_test.json (new)" in said
    assert len(read_annotations(package / "arm1_train.json")) == 4
    assert len(read_annotations(package / "arm1_test.json")) == 4


@pytest.mark.parametrize(("flags", "message"), [
    (["--train-clips", "-1"], "argument --train-clips: expected a whole number of at least 0"),
    (["--test-clips", "-5"], "argument --test-clips: expected a whole number of at least 0"),
    (["--train-clips", "0", "--test-clips", "0"], "both 0: nothing to write"),
])
def test_a_count_that_writes_nothing_is_refused_before_work(tmp_path: Path, flags: list[str],
                                                            message: str) -> None:
    assert message in refused(SCRIPT, flags, tmp_path)


def test_help_gives_every_option_its_default() -> None:
    helps = option_helps(SCRIPT)
    assert [flag for flag, text in helps.items() if "default" not in text] == []
    assert "(default: runs/data in the working directory)" in helps["--out"]
    assert "4 images each" in helps["--train-clips"]
