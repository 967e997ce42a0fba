"""An SO-101 follower arm on its Feetech bus: six STS3215 servos, one half-duplex serial line,
driven safely with the owner's LeRobot calibration.

Safety, in `SO101Bus`:

- Nothing is written before all six servos answered a PING and their Present_Position,
  Min/Max_Position_Limit and Homing_Offset were read; the limits and offset must equal the
  calibration file's (the file belongs to this arm).
- Every goal lies inside [range_min, range_max] and moves at most ``max_step_deg`` (motor
  degrees) from the previous goal; the first goal is the present position, so the arm ramps
  from where it stands to the first target.
- A frame with trust 0 re-sends the last goal; so does a joint whose target is not finite.
- `SO101Bus.close` (also the context manager's exit) releases the torque of every servo
  (or leaves it on with ``on_exit="hold"``); it never raises, whatever stopped the program.

How the defaults were chosen: docs/decisions/so101-bus.md.
"""

from __future__ import annotations

import contextlib
import logging
import math
import sys
from collections.abc import Mapping
from typing import TYPE_CHECKING, TextIO

from imimic_gym.hardware.calibration import SO101_JOINTS, STEPS_PER_TURN, SO101Calibration
from imimic_gym.hardware.feetech import (
    GOAL_POSITION,
    HOMING_OFFSET,
    MIN_POSITION_LIMIT,
    PRESENT_POSITION,
    TORQUE_ENABLE,
    BusError,
    ProtocolError,
    Register,
    StatusTimeoutError,
    decode_sign_magnitude,
    describe_packet,
    ping_packet,
    read_packet,
    read_status,
    sync_write_packet,
    write_packet,
)

if TYPE_CHECKING:
    import serial

__all__ = [
    "DEFAULT_MAX_STEP_DEG",
    "CalibrationMismatchError",
    "PortLostError",
    "PortUnavailableError",
    "SO101Bus",
    "ServosNotAnsweringError",
    "StartOutOfRangeError",
]

log = logging.getLogger(__name__)

DEFAULT_MAX_STEP_DEG = 4.0
_ON_EXIT = ("torque_off", "hold")
_WRITE_TIMEOUT_S = 1.0
_STEPS_PER_DEG = (STEPS_PER_TURN - 1) / 360  # LeRobot's scale: 4095 steps span 360 degrees

try:  # a vanished tty fails with termios.error, not OSError (POSIX)
    import termios

    _TTY_ERRORS: tuple[type[BaseException], ...] = (termios.error,)
except ImportError:  # Windows: pyserial reports everything as SerialException
    _TTY_ERRORS = ()


class PortUnavailableError(BusError):
    """The serial port cannot be opened (absent, busy, no permission)."""


class PortLostError(BusError):
    """The serial port failed while in use (unplugged)."""


class ServosNotAnsweringError(BusError):
    """Servos of the calibration did not answer a PING; ``missing`` holds their names."""

    def __init__(self, message: str, missing: list[str]) -> None:
        super().__init__(message)
        self.missing = missing


class CalibrationMismatchError(BusError):
    """A servo's stored limits or homing offset differ from the calibration file's."""


class StartOutOfRangeError(BusError):
    """A joint stands further outside its calibrated range than one ``max_step_deg`` step."""


class SO101Bus:
    """Goal positions for the six servos of an SO-101, one SYNC_WRITE per `send`.

    Args:
        port: the bus adapter's serial device (``/dev/ttyACM0``, ``COM3``, a pty).
        calibration: the arm's LeRobot calibration (`load_calibration`, `find_calibration`).
        baud: bits/s; LeRobot sets the STS3215s to 1 000 000.
        max_step_deg: most a goal may move per `send`, motor degrees (the gripper's motor
            too); applied in whole steps, 4095 per 360 degrees.
        on_exit: ``"torque_off"`` (release every servo; the arm sags under gravity) or
            ``"hold"`` (leave the torque on at the last goal). ``"torque-off"`` is accepted.
        dry_run: False to drive the arm; True to print each packet (hex and meaning) to
            stdout instead of opening the port, or a text stream to print them to. Present
            positions are then taken as the middle of each range.
        timeout_s: seconds to wait for one servo's answer.
        tries: attempts per PING, READ or acknowledged WRITE before giving up.

    Use as a context manager, or call `connect` and then `close` in a ``finally``.
    """

    def __init__(self, port: str, calibration: SO101Calibration, *, baud: int = 1_000_000,
                 max_step_deg: float = DEFAULT_MAX_STEP_DEG, on_exit: str = "torque_off",
                 dry_run: bool | TextIO = False, timeout_s: float = 0.1,
                 tries: int = 2) -> None:
        on_exit = on_exit.replace("-", "_")
        if on_exit not in _ON_EXIT:
            raise ValueError(f"on_exit must be 'torque_off' or 'hold', got {on_exit!r}")
        if not (math.isfinite(max_step_deg) and max_step_deg * _STEPS_PER_DEG >= 1):
            raise ValueError(f"max_step_deg must be finite and at least one step "
                             f"({1 / _STEPS_PER_DEG:.3f} degrees), got {max_step_deg}")
        if not timeout_s > 0:
            raise ValueError(f"timeout_s must be positive, got {timeout_s}")
        if not tries >= 1:
            raise ValueError(f"tries must be at least 1, got {tries}")
        self.port, self.calibration, self.baud = port, calibration, baud
        self.max_step_deg, self.on_exit = max_step_deg, on_exit
        self.timeout_s, self.tries = timeout_s, tries
        self._max_step_raw = math.floor(max_step_deg * _STEPS_PER_DEG)  # whole steps
        self._dry_log: TextIO | None = (sys.stdout if dry_run is True
                                        else dry_run if dry_run is not False else None)
        self._ids = calibration.ids()
        self._names = {servo_id: name for name, servo_id in self._ids.items()}
        self._serial: serial.Serial | None = None
        self._goal: dict[str, int] | None = None   # raw steps, last sent
        self._torque_on = False
        self.start_raw: dict[str, int] = {}         # Present_Position at connect, steps

    @property
    def connected(self) -> bool:
        return self._goal is not None

    @property
    def dry_run(self) -> bool:
        return self._dry_log is not None

    def last_goal(self) -> dict[str, float]:
        """The goals last sent, user units (degrees; gripper 0..100)."""
        if self._goal is None:
            raise BusError(f"{self.port}: not connected")
        return {name: self.calibration.to_user(name, raw) for name, raw in self._goal.items()}

    # -- connecting ---------------------------------------------------------------------

    def connect(self) -> None:
        """Open the port, check the six servos, hold them where they stand, torque on.

        Raises:
            PortUnavailableError: the port cannot be opened.
            ServosNotAnsweringError: servos that did not answer (none answered: the message
                says so).
            CalibrationMismatchError: a servo's stored limits or offset are not the file's.
            StartOutOfRangeError: a joint stands more than ``max_step_deg`` outside its
                range (within that, its first goal is the range's end).
            BusError: other protocol failures (garbled answers, servo error bits).
        In every case nothing was written to the bus, or the torque was released again.
        """
        if self.connected:
            return
        if self.dry_run:
            present = {name: (m.range_min + m.range_max) // 2
                       for name, m in self.calibration.motors.items()}
            self._note("dry run: no port opened; present positions taken as the middle of "
                       "each range")
        else:
            self._open()
            try:
                present = self._handshake()
            except BaseException:
                self._close_port()
                raise
        self.start_raw = present
        self._goal = {name: self._clamp(name, raw) for name, raw in present.items()}
        try:
            self._send_goal(self._goal)
            self._torque_on = True  # from here on, close() releases whatever was enabled
            for name in SO101_JOINTS:
                self._write_acknowledged(name, TORQUE_ENABLE, 1)
        except BaseException:
            self.close()
            raise
        log.info("SO-101 on %s: six servos found, torque on", self.port)

    def _open(self) -> None:
        import serial

        try:
            # pyserial raises a write timeout once the time is up even when every byte went
            # out: a generous one, so a busy machine does not pass for a lost port.
            self._serial = serial.Serial(self.port, self.baud, timeout=min(0.01, self.timeout_s),
                                         write_timeout=_WRITE_TIMEOUT_S, exclusive=True)
        except (OSError, ValueError, serial.SerialException) as err:
            raise PortUnavailableError(f"{self.port}: cannot open the SO-101 bus ({err})") \
                from None

    def _handshake(self) -> dict[str, int]:
        """PING all, compare stored calibration, read present positions (steps)."""
        missing = [name for name in SO101_JOINTS if not self._ping(name)]
        if len(missing) == len(SO101_JOINTS):
            ids = ", ".join(str(self._ids[name]) for name in missing)
            raise ServosNotAnsweringError(
                f"{self.port}: no servo answered (ids {ids}) at {self.baud} baud: is the arm "
                f"powered, and the port its bus adapter's?", missing)
        if missing:
            listed = ", ".join(f"{self._ids[name]} ({name})" for name in missing)
            raise ServosNotAnsweringError(f"{self.port}: no answer from servo id(s) {listed}",
                                          missing)
        present = {}
        for name, motor in self.calibration.motors.items():
            limits = self._read(name, MIN_POSITION_LIMIT.address, 4)  # min, then max
            stored = (limits & 0xFFFF, limits >> 16,
                      decode_sign_magnitude(self._read(name, HOMING_OFFSET.address, 2), 11))
            expected = (motor.range_min, motor.range_max, motor.homing_offset)
            if stored != expected:
                raise CalibrationMismatchError(
                    f"{self.port}: servo {motor.id} ({name}) holds range {stored[0]}..{stored[1]}"
                    f", homing offset {stored[2]}; the calibration "
                    f"({self.calibration.source or 'given'}) says {expected[0]}..{expected[1]},"
                    f" {expected[2]} (another arm's file, or one LeRobot has not written to "
                    f"the servos yet)")
            present[name] = self._read(name, PRESENT_POSITION.address, 2)
        for name, raw in present.items():
            off_by = abs(raw - self._clamp(name, raw))
            if off_by > self._max_step_raw:
                motor = self.calibration.motors[name]
                raise StartOutOfRangeError(
                    f"{self.port}: {name} stands at step {raw}, {off_by} steps outside its "
                    f"calibrated range {motor.range_min}..{motor.range_max}: move it into "
                    f"range by hand, or recalibrate")
        return present

    # -- commanding ---------------------------------------------------------------------

    def send(self, targets: Mapping[str, float], trust: float = 1.0) -> dict[str, float]:
        """Command joint targets with one SYNC_WRITE of Goal_Position to all six servos.

        Args:
            targets: joint name (``"shoulder_pan"`` or LeRobot's ``"shoulder_pan.pos"``) ->
                target, degrees for the body joints, 0..100 for the gripper. Joints left out,
                and targets that are not finite, keep their last goal.
            trust: the frame's trust; 0 (or not above 0) re-sends the last goals.

        Returns:
            joint name -> the goal actually sent, user units (after clamping to the
            calibrated range and limiting the step).

        Raises:
            ValueError: a name that is not an SO-101 joint.
            PortLostError: the port failed; the servos keep their last goal.
        """
        if self._goal is None:
            raise BusError(f"{self.port}: send before connect")
        wanted = {}
        for key, value in targets.items():
            name = key.removesuffix(".pos")
            if name not in self._goal:
                raise ValueError(f"unknown joint {key!r}; the SO-101's are "
                                 f"{', '.join(SO101_JOINTS)}")
            wanted[name] = float(value)
        goal = dict(self._goal)
        if trust > 0:
            for name, value in wanted.items():
                if math.isfinite(value):
                    # Past a full turn every target lies outside the range: bounding it
                    # first keeps huge values from overflowing int() in to_raw.
                    value = min(360.0, max(-360.0, value))
                    target = self._clamp(name, self.calibration.to_raw(name, value))
                    last = self._goal[name]
                    goal[name] = min(last + self._max_step_raw,
                                     max(last - self._max_step_raw, target))
        self._send_goal(goal)
        self._goal = goal
        return self.last_goal()

    def _clamp(self, name: str, raw: int) -> int:
        motor = self.calibration.motors[name]
        return min(motor.range_max, max(motor.range_min, raw))

    def _send_goal(self, goal: Mapping[str, int]) -> None:
        self._send(sync_write_packet(GOAL_POSITION, {self._ids[name]: goal[name]
                                                     for name in SO101_JOINTS}))

    # -- closing ------------------------------------------------------------------------

    def close(self) -> None:
        """Release the torque (``on_exit="torque_off"``) and close the port. Idempotent;
        never raises for a failing port (it logs a warning instead)."""
        try:
            if self._torque_on and self.on_exit == "torque_off":
                self._release_torque()
        finally:
            self._torque_on = False
            self._goal = None
            self._close_port()

    def _release_torque(self) -> None:
        unconfirmed = []
        for name in SO101_JOINTS:
            try:
                self._write_acknowledged(name, TORQUE_ENABLE, 0)
            except PortLostError as err:
                log.warning("%s; the servos' torque could not be released", err)
                return
            except BusError as err:
                log.warning("torque off for %s not confirmed: %s", name, err)
                unconfirmed.append(name)
        if not unconfirmed:
            log.info("SO-101 on %s: torque off", self.port)

    def _close_port(self) -> None:
        if self._serial is not None:
            import serial

            # Closing a port that is already gone is best effort.
            with contextlib.suppress(OSError, serial.SerialException, *_TTY_ERRORS):
                self._serial.close()
            self._serial = None

    def __enter__(self) -> SO101Bus:
        self.connect()
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # -- packets ------------------------------------------------------------------------

    def _note(self, line: str) -> None:
        assert self._dry_log is not None
        print(line, file=self._dry_log, flush=True)

    def _send(self, packet: bytes) -> None:
        if self._dry_log is not None:
            self._note(describe_packet(packet, self._names))
            return
        import serial

        assert self._serial is not None
        try:
            self._serial.write(packet)
        except (OSError, serial.SerialException, *_TTY_ERRORS) as err:
            raise PortLostError(f"{self.port}: the SO-101 bus failed ({err})") from None

    def _request(self, packet: bytes, servo_id: int) -> int:
        """Send ``packet`` to ``servo_id`` and return the answer's params as one
        little-endian integer, trying up to ``tries`` times."""
        import serial

        assert self._serial is not None
        connection = self._serial
        attempts_left = self.tries
        while True:
            try:
                connection.reset_input_buffer()  # nothing stale before the answer
                self._send(packet)
                return read_status(connection.read, servo_id, self.timeout_s).value()
            except (OSError, serial.SerialException, *_TTY_ERRORS) as err:
                raise PortLostError(f"{self.port}: the SO-101 bus failed ({err})") from None
            except (StatusTimeoutError, ProtocolError):
                attempts_left -= 1
                if not attempts_left:
                    raise

    def _ping(self, name: str) -> bool:
        try:
            self._request(ping_packet(self._ids[name]), self._ids[name])
        except StatusTimeoutError:
            return False
        return True

    def _read(self, name: str, address: int, size: int) -> int:
        return self._request(read_packet(self._ids[name], address, size), self._ids[name])

    def _write_acknowledged(self, name: str, register: Register, value: int) -> None:
        packet = write_packet(self._ids[name], register, value)
        if self.dry_run:
            self._send(packet)
        else:
            self._request(packet, self._ids[name])
