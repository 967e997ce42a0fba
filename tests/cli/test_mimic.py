"""`imimic mimic`'s options, each checked by what it changes in the outputs."""

import csv
import os

import cv2
import numpy as np
import pytest

import imimic_gym.rollout
from imimic_gym.cli import main
from imimic_gym.clips.cache import load_clip
from imimic_gym.clips.scenarios import get_scenario
from imimic_gym.clips.video_writer import write_video
from imimic_gym.metrics import angle_rmse_deg
from tests.clock import FakeClock

FPS = 30.0  # the servo_mp4 fixture's frame rate (90 frames of 320x240)


@pytest.fixture
def clock(monkeypatch: pytest.MonkeyPatch) -> FakeClock:
    """The episode loop's clock, patched: pacing is read off it, and no test waits."""
    fake = FakeClock()
    monkeypatch.setattr(imimic_gym.rollout, "time", fake)
    return fake


def mimic(video, out, *options: str) -> None:
    assert main(["mimic", "--video", str(video), "--estimator", "don",
                 "--reference-direction", "90", "--max-seconds", "0.5", "--out", str(out),
                 *options]) == 0


def video_size(path) -> tuple[int, int, int]:
    """(width, height, frames) of a video file."""
    capture = cv2.VideoCapture(str(path))
    try:
        return (int(capture.get(cv2.CAP_PROP_FRAME_WIDTH)),
                int(capture.get(cv2.CAP_PROP_FRAME_HEIGHT)),
                int(capture.get(cv2.CAP_PROP_FRAME_COUNT)))
    finally:
        capture.release()


def test_realtime_plays_the_file_at_its_own_frame_rate(servo_mp4, tmp_path, clock) -> None:
    """15 frames (0.5 s): before each frame after the first, the loop waits out the rest
    of the frame's 1/30 s; here no time passes otherwise, so each wait is the whole."""
    mimic(servo_mp4, tmp_path / "out", "--realtime")
    assert clock.sleeps == pytest.approx([1 / FPS] * 14, abs=1e-9)


def test_without_realtime_a_file_plays_as_fast_as_it_is_read(servo_mp4, tmp_path,
                                                            clock) -> None:
    mimic(servo_mp4, tmp_path / "out")
    assert clock.sleeps == []


@pytest.mark.parametrize(("height", "size"), [
    ("120", (320, 120)),  # two 160x120 panels, the footage halved
    ("100", (266, 100)),  # 320 * 100 / 240 = 133 wide a panel
    ("0", (640, 240)),    # the footage's own size
    ("480", (640, 240)),  # taller than the footage: never enlarged
])
def test_preview_height_sets_the_rows_of_mimic_mp4(servo_mp4, tmp_path, height: str,
                                                   size: tuple[int, int]) -> None:
    mimic(servo_mp4, tmp_path / "out", "--preview-height", height)
    assert video_size(tmp_path / "out" / "mimic.mp4") == (*size, 15)


def servo_lines(video, out, zero: str) -> list[float]:
    """The servo angles (degrees) `mimic --serial` writes to a pseudo-terminal."""
    controller, device = os.openpty()
    try:
        mimic(video, out, "--serial", os.ttyname(device), "--servo-zero", zero)
        os.set_blocking(controller, False)
        lines = os.read(controller, 65536).decode().splitlines()
    finally:
        os.close(controller)
        os.close(device)
    assert lines and all(line.startswith("J1 ") for line in lines)
    return [float(line.split()[1]) for line in lines]


def test_servo_zero_shifts_every_servo_angle_by_as_much(servo_mp4, tmp_path, clock) -> None:
    """The same run with joint angle 0 at servo 60 and at servo 45: the first command (sent
    at once) and the last (sent at the end) are 15 degrees apart; the commands between
    depend on the servo's rate limit, which reads the real clock."""
    at_60 = servo_lines(servo_mp4, tmp_path / "60", "60")
    at_45 = servo_lines(servo_mp4, tmp_path / "45", "45")
    assert at_60[0] - at_45[0] == pytest.approx(15.0, abs=0.11)
    assert at_60[-1] - at_45[-1] == pytest.approx(15.0, abs=0.11)


@pytest.fixture(scope="module")
def person_video(tmp_path_factory: pytest.TempPathFactory):
    """The rendered person (default scenario, seed 5, 30 frames) who moves their left arm
    and keeps the right one still; its truth, and the mp4 of it."""
    clip = load_clip(get_scenario("default", seed=5, n_frames=30), progress=False)
    path = tmp_path_factory.mktemp("person") / "person.mp4"
    write_video(path, clip.frames, clip.fps)
    return clip, path


def elbow_angles(out) -> np.ndarray:
    with (out / "mimic.csv").open(newline="") as table:
        return np.array([float(row["angle_rad"]) for row in csv.DictReader(table)])


def test_arm_chooses_which_of_the_persons_arms_is_copied(person_video, tmp_path) -> None:
    """Measured with the real pose model: --arm left follows the moving arm to 5.7 deg
    RMSE (bound twice that); --arm right reads the still arm (0 deg all along), 74 deg
    from the moving one."""
    clip, video = person_video
    truth = clip.truth.angles
    for arm in ("left", "right"):
        assert main(["mimic", "--video", str(video), "--estimator", "pose", "--arm", arm,
                     "--out", str(tmp_path / arm)]) == 0
    left, right = elbow_angles(tmp_path / "left"), elbow_angles(tmp_path / "right")
    assert len(left) == len(right) == 30
    assert angle_rmse_deg(left[:, None], truth) < 11.5
    assert angle_rmse_deg(right[:, None], truth) > 50
    assert np.degrees(np.ptp(right)) < 5 < np.degrees(np.ptp(left))
