"""LeRobot calibration files: validation, where LeRobot keeps them, and LeRobot's units."""

import copy
import json

import pytest

from imimic_gym.hardware import (
    SO101_JOINTS,
    CalibrationError,
    calibration_paths,
    find_calibration,
    load_calibration,
)
from imimic_gym.hardware.calibration import SO101Calibration
from tests.hardware.conftest import FOLLOWER

STEP_DEG = 360 / 4095


def test_the_file_loads_in_joint_order(calibration, calibration_file) -> None:
    assert tuple(calibration.motors) == SO101_JOINTS
    assert calibration.source == calibration_file
    assert calibration.motors["elbow_flex"].mid == 1975.5
    assert calibration.ids() == {"shoulder_pan": 1, "shoulder_lift": 2, "elbow_flex": 3,
                                 "wrist_flex": 4, "wrist_roll": 5, "gripper": 6}


@pytest.mark.parametrize(("joint", "value", "raw"), [
    ("shoulder_pan", 0.0, 2025),      # mid of 758..3292
    ("shoulder_pan", 30.0, 2366),     # 30 * 4095 / 360 = 341.25; + 2025 = 2366.25
    ("shoulder_pan", -45.5, 1507),    # -517.5625 + 2025 = 1507.4375
    ("elbow_flex", 10.0, 2089),       # 113.75 + 1975.5 = 2089.25
    ("elbow_flex", -10.0, 1861),      # -113.75 + 1975.5 = 1861.75
    ("wrist_roll", -180.5, -8),       # -2053.1875 + 2045 = -8.1875: int() cuts toward zero
    ("gripper", 25.0, 2402),          # 0.25 * 1491 + 2030 = 2402.75
    ("gripper", 0.0, 2030),
    ("gripper", 100.0, 3521),
    ("gripper", 120.0, 3521),         # LeRobot bounds the gripper to 0..100
    ("gripper", -5.0, 2030),
])
def test_user_units_to_steps_as_lerobot(calibration, joint, value, raw) -> None:
    assert calibration.to_raw(joint, value) == raw


def test_steps_to_user_units_as_lerobot(calibration) -> None:
    assert calibration.to_user("shoulder_pan", 2366) == pytest.approx(341 * 360 / 4095)
    assert calibration.to_user("elbow_flex", 1975) == pytest.approx(-0.5 * 360 / 4095)
    assert calibration.to_user("gripper", 2402) == pytest.approx(372 / 1491 * 100)
    assert calibration.to_user("gripper", 4000) == 100.0  # bounded to the range first


def test_drive_mode_inverts_the_gripper_only(calibration) -> None:
    motors = dict(calibration.motors)
    for joint in ("gripper", "elbow_flex"):
        motors[joint] = type(motors[joint])(**{**vars(motors[joint]), "drive_mode": 1})
    inverted = SO101Calibration(motors)
    assert inverted.to_raw("gripper", 25.0) == 3148          # 75 % of 1491 + 2030 = 3148.25
    assert inverted.to_user("gripper", 2402) == pytest.approx(100 - 372 / 1491 * 100)
    assert inverted.to_raw("elbow_flex", 10.0) == 2089       # degrees: LeRobot ignores it


def test_round_trips_lose_at_most_one_step(calibration) -> None:
    for joint, motor in calibration.motors.items():
        for raw in range(motor.range_min, motor.range_max + 1):
            back = calibration.to_raw(joint, calibration.to_user(joint, raw))
            assert raw - 1 <= back <= raw, (joint, raw, back)
        if joint == "gripper":
            values, one_step = [i / 10 for i in range(1001)], 100 / (motor.range_max -
                                                                    motor.range_min)
        else:
            values, one_step = [i / 10 for i in range(-1000, 1001)], STEP_DEG
        for value in values:
            again = calibration.to_user(joint, calibration.to_raw(joint, value))
            assert abs(again - value) <= one_step + 1e-9, (joint, value, again)


def broken(change) -> dict:
    data = copy.deepcopy(FOLLOWER)
    change(data)
    return data


@pytest.mark.parametrize(("data", "message"), [
    (broken(lambda d: d.pop("gripper")), "missing motor(s) gripper"),
    (broken(lambda d: d["elbow_flex"].pop("range_max")),
     "motor 'elbow_flex' is missing range_max"),
    (broken(lambda d: d["shoulder_pan"].update(range_min=12.5)),
     "'shoulder_pan'.range_min must be an integer, got 12.5"),
    (broken(lambda d: d["wrist_flex"].update(drive_mode=True)),
     "'wrist_flex'.drive_mode must be an integer, got True"),
    (broken(lambda d: d["wrist_flex"].update(drive_mode=2)),
     "'wrist_flex'.drive_mode must be 0 or 1, got 2"),
    (broken(lambda d: d["elbow_flex"].update(range_min=3000, range_max=2000)),
     "'elbow_flex' needs 0 <= range_min < range_max <= 4095, got 3000..2000"),
    (broken(lambda d: d["elbow_flex"].update(range_max=4096)),
     "'elbow_flex' needs 0 <= range_min < range_max <= 4095, got 881..4096"),
    (broken(lambda d: d["wrist_roll"].update(id=4)), "'wrist_flex' and 'wrist_roll' share id 4"),
    (broken(lambda d: d["gripper"].update(id=254)), "'gripper'.id must be 0..253, got 254"),
    (broken(lambda d: d["gripper"].update(homing_offset=-2048)),
     "'gripper'.homing_offset must be -2047..2047, got -2048"),
    (broken(lambda d: d.update(base={})), "unknown motor(s) base"),
    (broken(lambda d: d.update(gripper=7)), "motor 'gripper' must be an object"),
    ([], "expected an object of motors, got list"),
])
def test_a_malformed_file_is_one_line_naming_the_file_and_the_fault(tmp_path, data,
                                                                    message) -> None:
    path = tmp_path / "follower.json"
    path.write_text(json.dumps(data))
    with pytest.raises(CalibrationError) as caught:
        load_calibration(path)
    assert str(caught.value).startswith(f"{path}: ")
    assert message in str(caught.value) and "\n" not in str(caught.value)


def test_not_json_and_no_file(tmp_path) -> None:
    path = tmp_path / "follower.json"
    path.write_text('{"shoulder_pan": ')
    with pytest.raises(CalibrationError, match=r"follower\.json: not JSON \(Expecting value"):
        load_calibration(path)
    with pytest.raises(CalibrationError, match=r"absent\.json: no such calibration file"):
        load_calibration(tmp_path / "absent.json")
    assert isinstance(CalibrationError("x"), ValueError)


@pytest.fixture
def lerobot_env(monkeypatch):
    """No LeRobot or Hugging Face variable of the user's leaks in."""
    for name in ("HF_LEROBOT_CALIBRATION", "HF_LEROBOT_HOME", "HF_HOME", "XDG_CACHE_HOME"):
        monkeypatch.delenv(name, raising=False)
    return monkeypatch


@pytest.mark.parametrize(("variables", "folder"), [
    ({"HF_LEROBOT_CALIBRATION": "cal"}, "cal"),
    ({"HF_LEROBOT_HOME": "home"}, "home/calibration"),
    ({"HF_HOME": "hf"}, "hf/lerobot/calibration"),
    ({"XDG_CACHE_HOME": "xdg"}, "xdg/huggingface/lerobot/calibration"),
])
def test_found_where_lerobot_keeps_it(lerobot_env, tmp_path, calibration_file, variables,
                                      folder) -> None:
    for name, value in variables.items():
        lerobot_env.setenv(name, str(tmp_path / value))
    robots = tmp_path / folder / "robots"
    assert calibration_paths("my_follower") == [robots / "so_follower" / "my_follower.json",
                                                robots / "so101_follower" / "my_follower.json"]
    with pytest.raises(CalibrationError, match=r"so_follower/other\.json: no calibration for "
                       r"robot id 'other' \(nor in .*so101_follower\); make it with "
                       r"lerobot-calibrate --robot.type=so101_follower"):
        find_calibration("other")
    # An older LeRobot's folder...
    older = robots / "so101_follower" / "my_follower.json"
    older.parent.mkdir(parents=True)
    older.write_text(calibration_file.read_text())
    assert find_calibration("my_follower").source == older
    # ...gives way to the newer one's.
    newer = robots / "so_follower" / "my_follower.json"
    newer.parent.mkdir(parents=True)
    newer.write_text(calibration_file.read_text())
    assert find_calibration("my_follower").source == newer


def test_the_default_is_the_users_cache(lerobot_env, tmp_path) -> None:
    lerobot_env.setenv("HOME", str(tmp_path))
    assert calibration_paths("arm")[0] == (tmp_path / ".cache/huggingface/lerobot/calibration"
                                           "/robots/so_follower/arm.json")
