"""A realistic SO-101 follower calibration (as lerobot-calibrate writes it) and the bus
emulator built from it, checked clean after every test."""

import json

import pytest

from imimic_gym.hardware import SO101Calibration, load_calibration
from tests.hardware.bus_emulator import FeetechBusEmulator

# Shaped like a real follower's file: ids 1..6, drive_mode 0, offsets from the half-turn
# homing, ranges recorded by moving each joint end to end.
FOLLOWER = {
    "shoulder_pan": {"id": 1, "drive_mode": 0, "homing_offset": -1470,
                     "range_min": 758, "range_max": 3292},
    "shoulder_lift": {"id": 2, "drive_mode": 0, "homing_offset": 157,
                      "range_min": 612, "range_max": 3401},
    "elbow_flex": {"id": 3, "drive_mode": 0, "homing_offset": 1105,
                   "range_min": 881, "range_max": 3070},
    "wrist_flex": {"id": 4, "drive_mode": 0, "homing_offset": -1390,
                   "range_min": 898, "range_max": 3209},
    "wrist_roll": {"id": 5, "drive_mode": 0, "homing_offset": 120,
                   "range_min": 107, "range_max": 3983},
    "gripper": {"id": 6, "drive_mode": 0, "homing_offset": 1423,
                "range_min": 2030, "range_max": 3521},
}


@pytest.fixture
def calibration_file(tmp_path):
    path = tmp_path / "my_follower.json"
    path.write_text(json.dumps(FOLLOWER, indent=4))
    return path


@pytest.fixture
def calibration(calibration_file) -> SO101Calibration:
    return load_calibration(calibration_file)


@pytest.fixture
def emulator(calibration):
    with FeetechBusEmulator(calibration) as bus:
        yield bus
        assert bus.errors == []
