"""`imimic mimic --robot so101` driving the emulated bus, as a user runs it: a rendered
person's video in, one goal SYNC_WRITE per frame out, decoded through the calibration to
the joint targets mimic.csv records; never outside the range, never faster than the
limit; the torque released at the end and after Ctrl-C; refusals before any write."""

import csv
import itertools
import json
import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from imimic_gym.hardware import load_calibration
from imimic_gym.hardware.calibration import SO101_JOINTS
from tests.hardware.bus_emulator import TORQUE, FeetechBusEmulator
from tests.hardware.conftest import FOLLOWER

FRAMES = 45
DEADLINE_S = 300  # a whole mimic run on a busy 2-core machine takes well under this
STEPS_PER_DEG = 4095 / 360


@pytest.fixture(scope="module")
def person_video(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A rendered person waving, 45 frames, as an mp4."""
    from imimic_gym.clips.cache import load_clip
    from imimic_gym.clips.scenarios import get_scenario
    from imimic_gym.clips.video_writer import write_video

    clip = load_clip(get_scenario("spatial-wave", n_frames=FRAMES, seed=2), progress=False)
    return write_video(tmp_path_factory.mktemp("wave") / "wave.mp4", clip.frames, clip.fps)


@pytest.fixture
def calibration_file(tmp_path: Path) -> Path:
    path = tmp_path / "my_follower.json"
    path.write_text(json.dumps(FOLLOWER))
    return path


def mimic(video: Path, out: Path, *options: str) -> subprocess.Popen:
    return subprocess.Popen(
        [sys.executable, "-m", "imimic_gym.cli", "mimic", "--video", str(video),
         "--robot", "so101", "--out", str(out), *options],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        env={**os.environ, "MUJOCO_GL": "egl"})


def finish(process: subprocess.Popen) -> tuple[int, str, str]:
    try:
        stdout, stderr = process.communicate(timeout=DEADLINE_S)
    except subprocess.TimeoutExpired:
        process.kill()
        stdout, stderr = process.communicate(timeout=30)
        raise AssertionError(
            f"imimic mimic did not end in {DEADLINE_S} s:\n{stderr[-2000:]}") from None
    return process.returncode, stdout, stderr


def csv_targets(out: Path) -> list[dict[str, float]]:
    with (out / "mimic.csv").open() as table:
        return [{name: float(row[f"{name}.pos"]) for name in SO101_JOINTS}
                for row in csv.DictReader(table)]


def torque_offs(emulator: FeetechBusEmulator) -> list[int]:
    """The servo ids of the last writes, where they set Torque_Enable to 0."""
    return [p.servo_id for p in emulator.writes()[-6:]
            if p.params[:2] == bytes([TORQUE, 0])]


def test_every_frame_is_one_sync_write_of_the_csvs_targets(person_video, calibration_file,
                                                           tmp_path) -> None:
    calibration = load_calibration(calibration_file)
    with FeetechBusEmulator(calibration, deadline_s=DEADLINE_S) as bus:
        code, _, stderr = finish(mimic(
            person_video, tmp_path / "out", "--port", bus.port, "--calibration",
            str(calibration_file), "--max-step-deg", "60"))
        assert code == 0, stderr[-2000:]
        assert bus.errors == []
        goals = bus.goal_writes()
        targets = csv_targets(tmp_path / "out")
        assert len(targets) == FRAMES
        # The first goal holds the servos where they stand (connect); then one a frame.
        assert len(goals) == 1 + FRAMES
        matched = 0
        for previous, goal, target in zip(goals, goals[1:], targets, strict=False):
            for name, servo_id in calibration.ids().items():
                motor = calibration.motors[name]
                raw = goal[servo_id]
                assert motor.range_min <= raw <= motor.range_max
                assert abs(raw - previous[servo_id]) <= 60 * STEPS_PER_DEG
                wanted = min(max(calibration.to_raw(name, target[name]), motor.range_min),
                             motor.range_max)
                matched += abs(raw - wanted) <= 1
        # Only the step limit may stand between a target and its goal: the wave's targets
        # move less than 60 degrees a frame after the first frames' ramp from rest.
        assert matched >= 0.9 * FRAMES * 6, f"{matched} of {FRAMES * 6} goals match"
        assert sorted(torque_offs(bus)) == sorted(calibration.ids().values())


def test_the_default_step_limit_holds_on_every_write(person_video, calibration_file,
                                                     tmp_path) -> None:
    calibration = load_calibration(calibration_file)
    with FeetechBusEmulator(calibration, deadline_s=DEADLINE_S) as bus:
        code, _, stderr = finish(mimic(person_video, tmp_path / "out", "--port", bus.port,
                                       "--calibration", str(calibration_file)))
        assert code == 0, stderr[-2000:]
        goals = bus.goal_writes()
        limit = int(4.0 * STEPS_PER_DEG)  # whole steps under the default 4 degrees
        steps = [abs(b[i] - a[i]) for a, b in itertools.pairwise(goals) for i in a]
        assert max(steps) <= limit
        assert max(steps) == limit  # the ramp from rest to the first targets uses it


def test_ctrl_c_releases_the_torque_and_exits_130(person_video, calibration_file,
                                                  tmp_path) -> None:
    calibration = load_calibration(calibration_file)
    with FeetechBusEmulator(calibration, deadline_s=DEADLINE_S) as bus:
        process = mimic(person_video, tmp_path / "out", "--port", bus.port, "--calibration",
                        str(calibration_file))
        # A few frames into the run (the bus paces it to the video's 30 frames/s).
        if not bus.wait_for(lambda: len(bus.goal_writes()) >= 6, timeout_s=DEADLINE_S):
            process.kill()
            raise AssertionError(
                f"no goal writes: {process.communicate(timeout=30)[1][-2000:]}")
        process.send_signal(signal.SIGINT)
        code, _, stderr = finish(process)
        assert code == 130, stderr[-2000:]
        assert len(bus.goal_writes()) < 1 + FRAMES
        assert sorted(torque_offs(bus)) == sorted(calibration.ids().values())
        assert "Traceback" not in stderr


@pytest.mark.parametrize("fault", ["malformed calibration", "unplugged port", "silent bus"])
def test_refusals_are_one_line_exit_2_and_write_nothing(fault, person_video,
                                                        calibration_file, tmp_path) -> None:
    calibration = load_calibration(calibration_file)
    with FeetechBusEmulator(calibration, silent=fault == "silent bus",
                            deadline_s=DEADLINE_S) as bus:
        port, given = bus.port, calibration_file
        if fault == "malformed calibration":
            given = tmp_path / "broken.json"
            given.write_text(json.dumps({**FOLLOWER, "gripper": {"id": 6}}))
        if fault == "unplugged port":
            port = str(tmp_path / "ttyACM9")
        code, _, stderr = finish(mimic(person_video, tmp_path / "out", "--port", port,
                                            "--calibration", str(given)))
        assert code == 2, stderr[-2000:]
        lines = [line for line in stderr.splitlines() if line.startswith("imimic mimic:")]
        assert len(lines) == 1 and "Traceback" not in stderr, stderr
        assert bus.writes() == []
        assert not (tmp_path / "out" / "mimic.csv").exists()


@pytest.mark.parametrize(("options", "message"), [
    (["--port", "/dev/ttyACM0"], "--port goes with --robot so101"),
    (["--mapping", "tilted"], "--mapping goes with --robot so101"),
    (["--fov", "70"], "--fov goes with --robot so101"),
    (["--robot", "so101", "--fov", "175"], "--fov takes .* 10 to 170 degrees, got 175"),
    (["--robot", "so101", "--fov", "5"], "--fov takes .* 10 to 170 degrees, got 5"),
    (["--robot", "so101", "--serial", "/dev/ttyUSB0"], "--serial is the planar arm's"),
    (["--robot", "so101", "--port", "/dev/ttyACM0"], "needs its LeRobot calibration"),
    (["--robot", "so101", "--estimator", "pose"], "reads angles in the image plane"),
    (["--estimator", "pose3d"], "give --robot so101"),
])
def test_options_that_do_not_go_together_are_refused_before_any_work(
        options, message, person_video, tmp_path) -> None:
    from imimic_gym.cli import main
    from imimic_gym.cli.common import CommandError

    with pytest.raises(CommandError, match=message):
        main(["mimic", "--video", str(person_video), "--out", str(tmp_path / "out"),
              *options])
    assert not (tmp_path / "out").exists()
