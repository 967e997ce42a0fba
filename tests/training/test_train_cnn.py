"""The real training script, run as a user runs it, with a tiny budget."""

import json
import subprocess
import sys
from pathlib import Path

import pytest

from imimic_gym.clips.annotations import read_annotations, write_annotations
from imimic_gym.clips.dataset import DEFAULT_ANNOTATIONS

from . import option_helps, refused

SCRIPT = Path(__file__).resolve().parents[2] / "training" / "train_cnn.py"


def run(*args: str, cwd: Path) -> str:
    done = subprocess.run([sys.executable, str(SCRIPT), *args], cwd=cwd, capture_output=True,
                          text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-3000:]
    return done.stdout


def test_one_epoch_run_writes_a_checkpoint_that_eval_only_scores_the_same(tmp_path: Path) -> None:
    test = tmp_path / "tiny_test.json"
    write_annotations(test, read_annotations(DEFAULT_ANNOTATIONS / "arm1_test.json")[:4])
    out = run("--limit", "14", "--cnn-epochs", "1", "--epochs", "1", "--threads", "1",
              "--test-annotations", str(test), "--out", "model/cnn.pt", cwd=tmp_path)
    assert "PCP@0.5" not in out.split("All 4 test images")[0]  # fewer than 20: no paper rows
    assert "All 4 test images" in out
    meta = json.loads((tmp_path / "model" / "cnn.json").read_text())
    assert meta["train_images"] == 14 and meta["keypoint_names"] == ["shoulder", "elbow", "wrist"]
    assert meta["input_hw"] == [60, 80] and meta["args"]["epochs"] == 1
    assert len(list((tmp_path / "runs").glob("cnn_arm1__1__*/log.csv"))) == 1

    run("--eval-only", "model/cnn.pt", "--annotations", str(test), "--json", "pcp.json",
        cwd=tmp_path)
    scored = json.loads((tmp_path / "pcp.json").read_text())
    trained = meta["test"]["cnn_refiner"]
    assert scored["cnn_refiner"]["pcp_all"] == trained["pcp_all"]
    # The same network scored twice: measured 2.6e-4 px apart, float32 round-off (issue 40:
    # a floor of 0.01 px).
    assert abs(scored["cnn_refiner"]["mean_pixel_error"] - trained["mean_pixel_error"]) < 0.01


def test_help_explains_every_option(tmp_path: Path) -> None:
    out = run("--help", cwd=tmp_path)
    for flag in ("--annotations", "--images", "--links", "--epochs", "--out", "--eval-only",
                 "--json", "--batch-size"):
        assert flag in out
    assert "paper: 14" in out


def test_help_gives_every_option_its_default_once() -> None:
    helps = option_helps(SCRIPT)
    assert [flag for flag, text in helps.items() if text.count("default") != 1] == []
    assert "(default: None)" not in " ".join(helps.values())
    assert "(default: 14)" in helps["--batch-size"] and "images per" in helps["--batch-size"]


def test_a_non_finite_loss_stops_training_and_writes_no_checkpoint(tmp_path: Path) -> None:
    test = tmp_path / "tiny_test.json"
    write_annotations(test, read_annotations(DEFAULT_ANNOTATIONS / "arm1_test.json")[:4])
    done = subprocess.run([sys.executable, str(SCRIPT), "--limit", "14", "--cnn-epochs", "2",
                           "--epochs", "2", "--threads", "1", "--learning-rate", "1e30",
                           "--test-annotations", str(test), "--out", "model/cnn.pt"],
                          cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert done.returncode != 0
    assert "the loss is nan in epoch 2" in done.stderr
    assert "no checkpoint written" in done.stderr
    assert not (tmp_path / "model" / "cnn.pt").exists()
    # The first epoch's loss is kept: the log says how the run went before it failed.
    logs = list((tmp_path / "runs").glob("cnn_arm1__1__*/log.csv"))
    assert len(logs) == 1 and ",losses/cnn," in logs[0].read_text()


def test_a_run_that_fails_in_its_first_epoch_leaves_no_run_folder(tmp_path: Path) -> None:
    """One image a step at a learning rate of 1e30: the second step's loss is not finite."""
    test = tmp_path / "tiny_test.json"
    write_annotations(test, read_annotations(DEFAULT_ANNOTATIONS / "arm1_test.json")[:4])
    done = subprocess.run([sys.executable, str(SCRIPT), "--limit", "4", "--batch-size", "1",
                           "--learning-rate", "1e30", "--threads", "1", "--test-annotations",
                           str(test)], cwd=tmp_path, capture_output=True, text=True,
                          timeout=300)
    assert done.returncode != 0 and "the loss is nan in epoch 1" in done.stderr
    assert (tmp_path / "runs").is_dir() and not list((tmp_path / "runs").iterdir())


def test_annotations_without_a_complete_arm_are_named(tmp_path: Path) -> None:
    empty = tmp_path / "empty.json"
    empty.write_text(json.dumps({"images": [{"id": 1, "file_name": "a.png", "width": 8,
                                             "height": 8}],
                                 "annotations": [],
                                 "categories": [{"id": 1, "name": "arm",
                                                 "keypoints": ["shoulder", "elbow", "wrist"]}]}))
    done = subprocess.run([sys.executable, str(SCRIPT), "--annotations", str(empty),
                           "--images", str(tmp_path), "--epochs", "1"], cwd=tmp_path,
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 2
    assert "empty.json has no image with a complete arm" in done.stderr
    assert "Traceback" not in done.stderr


def test_a_missing_annotations_file_is_one_line(tmp_path: Path) -> None:
    done = subprocess.run([sys.executable, str(SCRIPT), "--annotations",
                           str(tmp_path / "nope.json")], cwd=tmp_path, capture_output=True,
                          text=True, timeout=120)
    assert done.returncode == 2 and "Traceback" not in done.stderr
    assert done.stderr.startswith("train_cnn.py:") and "nope.json" in done.stderr


@pytest.mark.parametrize(("flags", "message"), [
    (["--batch-size", "0"], "argument --batch-size: expected a whole number of at least 1"),
    (["--learning-rate", "nan"], "argument --learning-rate: expected a finite number above"),
    (["--epochs", "-1"], "argument --epochs: expected a whole number of at least 0"),
    (["--cnn-epochs", "0", "--epochs", "0"], "both 0: nothing to train"),
    (["--seed", "-1"], "argument --seed: expected a whole number of at least 0"),
    (["--test-annotations", "nope.json"], "nope.json"),
    (["--init", "nope.pt"], "checkpoint nope.pt not found"),
    (["--images", "nowhere", "--limit", "2"], "nowhere/arm1/train/"),
    # Outputs, before the training rather than after it (/proc refuses even root's writes).
    (["--out", "/proc/cnn.pt", "--limit", "2", "--cnn-epochs", "1", "--epochs", "0"],
     "train_cnn.py: --out /proc/cnn.pt: /proc is not writable"),
    (["--json", "/proc/pcp.json", "--limit", "2", "--cnn-epochs", "1", "--epochs", "0"],
     "train_cnn.py: --json /proc/pcp.json: /proc is not writable"),
    (["--split", "shuffled"], "--split takes random or time, got 'shuffled'"),
    (["--split", "time"], "not with --test-annotations, --eval-only or the shipped dataset"),
    (["--annotations", "a.json", "--test-annotations", "b.json", "--test-fraction", "0.3"],
     "not with --test-annotations"),
    (["--test-fraction", "1"], "argument --test-fraction: expected a number between 0 and 1"),
])
def test_a_bad_input_is_one_line_before_a_run_folder_exists(tmp_path: Path, flags: list[str],
                                                            message: str) -> None:
    assert message in refused(SCRIPT, flags, tmp_path)


def test_split_time_trains_on_a_videos_first_frames_and_tests_on_its_last(
        tmp_path: Path) -> None:
    from dataclasses import replace

    arms = read_annotations(DEFAULT_ANNOTATIONS / "arm1_train.json")[:20]
    # Frames of one video, listed out of order: the split follows the image ids.
    frames = [replace(arm, image_id=100 + k) for k, arm in enumerate(arms)]
    write_annotations(tmp_path / "video.json", frames[10:] + frames[:10])
    run("--annotations", str(tmp_path / "video.json"), "--split", "time", "--cnn-epochs", "1",
        "--epochs", "1", "--threads", "1", "--out", "cnn.pt", cwd=tmp_path)
    (folder,) = (tmp_path / "runs").iterdir()
    train = [arm.image_id for arm in read_annotations(folder / "split_train.json")]
    test = [arm.image_id for arm in read_annotations(folder / "split_test.json")]
    assert train == list(range(100, 114)) and test == list(range(114, 120))  # 70% / 30%
    meta = json.loads((tmp_path / "cnn.json").read_text())
    assert meta["train_images"] == 14 and meta["test"]["n_images"] == 6
    assert meta["args"]["split"] == "time"
