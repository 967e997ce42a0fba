"""The SO-101 follower's LeRobot calibration file, and LeRobot's conversion between user
units and raw servo steps.

The file (``lerobot-calibrate`` writes it) maps each motor name to
``{"id", "drive_mode", "homing_offset", "range_min", "range_max"}``, integers, ranges in
raw steps (0..4095, one turn = 4096 steps). ``homing_offset`` lives in the servo itself
(the servo reports Present_Position = actual - Homing_Offset); the conversion below does
not use it, as LeRobot's MotorsBus does not.

User units are LeRobot's for an ``so101_follower`` with ``use_degrees=True``:

- the five body joints: degrees, 0 at the middle of [range_min, range_max]:
  degrees = (raw - mid) * 360 / 4095. LeRobot ignores ``drive_mode`` here.
- the gripper: 0..100 over [range_min, range_max], 100 - value when ``drive_mode`` is 1.

Raw values come out of `SO101Calibration.to_raw` truncated by ``int`` as LeRobot's
``_unnormalize`` does, so a joint target gives the very step LeRobot would send.
"""

from __future__ import annotations

import json
import os
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

from imimic_gym.hardware.feetech import MAX_SERVO_ID

__all__ = [
    "GRIPPER",
    "SO101_JOINTS",
    "STEPS_PER_TURN",
    "CalibrationError",
    "MotorCalibration",
    "SO101Calibration",
    "calibration_dir",
    "calibration_paths",
    "find_calibration",
    "load_calibration",
    "parse_calibration",
]

SO101_JOINTS = ("shoulder_pan", "shoulder_lift", "elbow_flex", "wrist_flex", "wrist_roll",
                "gripper")
GRIPPER = "gripper"
STEPS_PER_TURN = 4096          # the STS3215's encoder resolution
_MAX_STEP = STEPS_PER_TURN - 1  # LeRobot's max_res: 360 degrees span 4095 steps
_FIELDS = ("id", "drive_mode", "homing_offset", "range_min", "range_max")
# The folders under <calibration dir>/robots/ where LeRobot saves a follower's file, newest
# layout first: LeRobot 0.5 merged the SO-100 and SO-101 into one robot named so_follower;
# earlier releases kept so101_follower.
ROBOT_FOLDERS = ("so_follower", "so101_follower")


class CalibrationError(ValueError):
    """A calibration file that is missing or wrong; the message is one line naming it."""


@dataclass(frozen=True)
class MotorCalibration:
    """One motor's calibration: bus ``id``, ``drive_mode`` (0 or 1), ``homing_offset``
    (steps, stored in the servo), ``range_min`` < ``range_max`` (steps)."""

    id: int
    drive_mode: int
    homing_offset: int
    range_min: int
    range_max: int

    @property
    def mid(self) -> float:
        """The middle of the range, steps: user 0 degrees."""
        return (self.range_min + self.range_max) / 2


@dataclass(frozen=True)
class SO101Calibration:
    """The six motors' calibrations, in `SO101_JOINTS` order; ``source`` is the file."""

    motors: Mapping[str, MotorCalibration]
    source: Path | None = None

    def to_raw(self, joint: str, value: float) -> int:
        """A joint target in user units (degrees; gripper 0..100) as raw steps, exactly as
        LeRobot's ``MotorsBus._unnormalize``. Body joints are not clamped here (LeRobot
        does not); the gripper is bounded to 0..100 (LeRobot does)."""
        motor = self.motors[joint]
        if joint == GRIPPER:
            value = 100 - value if motor.drive_mode else value
            bounded = min(100.0, max(0.0, value))
            return int(bounded / 100 * (motor.range_max - motor.range_min) + motor.range_min)
        return int(value * _MAX_STEP / 360 + motor.mid)

    def to_user(self, joint: str, raw: int) -> float:
        """Raw steps as user units (degrees; gripper 0..100), exactly as LeRobot's
        ``MotorsBus._normalize``: the gripper's raw value is bounded to the range first."""
        motor = self.motors[joint]
        if joint == GRIPPER:
            bounded = min(motor.range_max, max(motor.range_min, raw))
            norm = (bounded - motor.range_min) / (motor.range_max - motor.range_min) * 100
            return 100 - norm if motor.drive_mode else norm
        return (raw - motor.mid) * 360 / _MAX_STEP

    def ids(self) -> dict[str, int]:
        """Motor name -> bus id."""
        return {name: motor.id for name, motor in self.motors.items()}


def _check_motor(where: str, name: str, entry: object) -> MotorCalibration:
    if not isinstance(entry, dict):
        raise CalibrationError(f"{where}: motor '{name}' must be an object with "
                               f"{', '.join(_FIELDS)}, got {entry!r}")
    missing = [field for field in _FIELDS if field not in entry]
    if missing:
        raise CalibrationError(f"{where}: motor '{name}' is missing {', '.join(missing)}")
    for field in _FIELDS:
        value = entry[field]
        if not isinstance(value, int) or isinstance(value, bool):
            raise CalibrationError(f"{where}: '{name}'.{field} must be an integer, "
                                   f"got {value!r}")
    motor = MotorCalibration(**{field: entry[field] for field in _FIELDS})
    if not 0 <= motor.id <= MAX_SERVO_ID:
        raise CalibrationError(f"{where}: '{name}'.id must be 0..{MAX_SERVO_ID}, "
                               f"got {motor.id}")
    if motor.drive_mode not in (0, 1):
        raise CalibrationError(f"{where}: '{name}'.drive_mode must be 0 or 1, "
                               f"got {motor.drive_mode}")
    if not abs(motor.homing_offset) <= 2047:  # sign-magnitude, 11 bits
        raise CalibrationError(f"{where}: '{name}'.homing_offset must be -2047..2047, "
                               f"got {motor.homing_offset}")
    if not 0 <= motor.range_min < motor.range_max <= _MAX_STEP:
        raise CalibrationError(f"{where}: '{name}' needs 0 <= range_min < range_max <= "
                               f"{_MAX_STEP}, got {motor.range_min}..{motor.range_max}")
    return motor


def parse_calibration(data: object, where: str = "calibration") -> SO101Calibration:
    """Validate a decoded calibration JSON; ``where`` names it in errors."""
    if not isinstance(data, dict):
        raise CalibrationError(f"{where}: expected an object of motors, got "
                               f"{type(data).__name__}")
    missing = [name for name in SO101_JOINTS if name not in data]
    if missing:
        raise CalibrationError(f"{where}: missing motor(s) {', '.join(missing)}")
    unknown = [name for name in data if name not in SO101_JOINTS]
    if unknown:
        raise CalibrationError(f"{where}: unknown motor(s) {', '.join(map(str, unknown))} "
                               f"(an SO-101 has {', '.join(SO101_JOINTS)})")
    motors = {name: _check_motor(where, name, data[name]) for name in SO101_JOINTS}
    seen: dict[int, str] = {}
    for name, motor in motors.items():
        if motor.id in seen:
            raise CalibrationError(f"{where}: '{seen[motor.id]}' and '{name}' share id "
                                   f"{motor.id}")
        seen[motor.id] = name
    return SO101Calibration(motors)


def load_calibration(path: str | os.PathLike[str]) -> SO101Calibration:
    """Read and validate a LeRobot SO-101 calibration JSON.

    Raises:
        CalibrationError: the file is missing, unreadable, not JSON, lacks a joint or a
            field, or holds a value out of bounds (one line naming the file and the fault).
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise CalibrationError(f"{path}: no such calibration file") from None
    except (OSError, UnicodeDecodeError) as err:
        raise CalibrationError(f"{path}: cannot be read ({err})") from None
    try:
        data = json.loads(text)
    except json.JSONDecodeError as err:
        raise CalibrationError(f"{path}: not JSON ({err})") from None
    calibration = parse_calibration(data, str(path))
    return SO101Calibration(calibration.motors, path)


def calibration_dir() -> Path:
    """Where LeRobot keeps calibrations: $HF_LEROBOT_CALIBRATION, else
    $HF_LEROBOT_HOME/calibration, else $HF_HOME/lerobot/calibration, else
    $XDG_CACHE_HOME/huggingface/lerobot/calibration (``~/.cache`` without XDG)."""
    if "HF_LEROBOT_CALIBRATION" in os.environ:
        return Path(os.environ["HF_LEROBOT_CALIBRATION"]).expanduser()
    if "HF_LEROBOT_HOME" in os.environ:
        return Path(os.environ["HF_LEROBOT_HOME"]).expanduser() / "calibration"
    cache = os.environ.get("XDG_CACHE_HOME", str(Path("~/.cache").expanduser()))
    hf_home = os.environ.get("HF_HOME", os.path.join(cache, "huggingface"))
    return Path(os.path.expandvars(hf_home)).expanduser() / "lerobot" / "calibration"


def calibration_paths(robot_id: str) -> list[Path]:
    """Where ``lerobot-calibrate --robot.type=so101_follower --robot.id=ROBOT_ID`` saves the
    file, newest LeRobot first: .../robots/so_follower/ROBOT_ID.json, then
    .../robots/so101_follower/ROBOT_ID.json."""
    return [calibration_dir() / "robots" / folder / f"{robot_id}.json"
            for folder in ROBOT_FOLDERS]


def find_calibration(robot_id: str) -> SO101Calibration:
    """Load the calibration LeRobot keeps for the follower ``robot_id``, from the first of
    `calibration_paths` that exists.

    Raises:
        CalibrationError: as `load_calibration`; no file names the places looked in and the
            command that makes one.
    """
    paths = calibration_paths(robot_id)
    for path in paths:
        if path.is_file():
            return load_calibration(path)
    raise CalibrationError(
        f"{paths[0]}: no calibration for robot id '{robot_id}' (nor in {paths[1].parent}); "
        f"make it with lerobot-calibrate --robot.type=so101_follower --robot.port=PORT "
        f"--robot.id={robot_id}")
