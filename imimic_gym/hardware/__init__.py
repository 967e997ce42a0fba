"""Real robots: the SO-101 arm's Feetech servo bus with its owner's LeRobot calibration."""

from imimic_gym.hardware.calibration import (
    SO101_JOINTS,
    CalibrationError,
    MotorCalibration,
    SO101Calibration,
    calibration_dir,
    calibration_paths,
    find_calibration,
    load_calibration,
    parse_calibration,
)
from imimic_gym.hardware.feetech import (
    BusError,
    ChecksumError,
    MalformedPacketError,
    ProtocolError,
    ServoError,
    StatusTimeoutError,
    WrongIdError,
)
from imimic_gym.hardware.so101 import (
    DEFAULT_MAX_STEP_DEG,
    CalibrationMismatchError,
    PortLostError,
    PortUnavailableError,
    ServosNotAnsweringError,
    SO101Bus,
    StartOutOfRangeError,
)

__all__ = [
    "DEFAULT_MAX_STEP_DEG",
    "SO101_JOINTS",
    "BusError",
    "CalibrationError",
    "CalibrationMismatchError",
    "ChecksumError",
    "MalformedPacketError",
    "MotorCalibration",
    "PortLostError",
    "PortUnavailableError",
    "ProtocolError",
    "SO101Bus",
    "SO101Calibration",
    "ServoError",
    "ServosNotAnsweringError",
    "StartOutOfRangeError",
    "StatusTimeoutError",
    "WrongIdError",
    "calibration_dir",
    "calibration_paths",
    "find_calibration",
    "load_calibration",
    "parse_calibration",
]
