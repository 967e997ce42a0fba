"""A serial bridge to a hobby-servo controller: the simulated arm's joint commands drive a
real servo arm, the paper's one-link arm on an Arduino (sketch: firmware/servo_arm/).

Protocol (text, one line per joint command, host to controller, 8N1 at the chosen baud):

    J<joint> <degrees>\\n        e.g. "J1 87.5\\n"

- ``joint`` counts from 1; ``degrees`` is the servo's own angle with one decimal, already
  clamped to its range (the paper's servo: 0 to 120). Joint angle q (rad, DESIGN.md
  convention) maps to ``zero_deg + degrees(q)``: with the defaults the joint's -60..60
  degrees span the servo's 0..120.
- The controller answers nothing (a host that stops reading can never block it); it
  clamps again on its side and holds the last position.

Commands are rate-limited (``max_rate_hz``, default 50: one per PWM period of a hobby
servo): a command that comes too soon is kept as pending and sent at the next chance (or
by `flush`), so the last pose of a motion is never lost. Unchanged commands are not sent
again. A port that fails (unplugged, a write error) is reported through ``logging`` and
re-opened every ``retry_s`` seconds; `send` never raises for it: a robot in mid-motion
must not crash because a cable slipped.
"""

from __future__ import annotations

import contextlib
import logging
import math
import time
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    import serial

__all__ = ["ServoBridge", "format_command"]

log = logging.getLogger(__name__)

try:  # a draining write on a vanished tty fails with termios.error, not OSError (POSIX)
    import termios

    _TTY_ERRORS: tuple[type[BaseException], ...] = (termios.error,)
except ImportError:  # Windows: pyserial reports everything as SerialException
    _TTY_ERRORS = ()


def format_command(joint: int, degrees: float) -> bytes:
    """The protocol line for ``joint`` (from 1) at ``degrees``: b"J1 87.5\\n"."""
    return f"J{joint} {degrees:.1f}\n".encode("ascii")


class ServoBridge:
    """Sends joint angles to a servo controller on a serial port (pyserial).

    Args:
        port: the serial device (``/dev/ttyACM0``, ``COM3``, a pty's name).
        baud: line speed, bits/s (the sketch uses 115200).
        servo_range_deg: the servo's (low, high) angle, degrees (paper: 0 to 120).
        zero_deg: the servo angle of joint angle 0.
        max_rate_hz: most commands per second per joint.
        retry_s: seconds between attempts to re-open a lost port.
        clock: seconds, monotonic; injectable so tests need no sleeping.

    Attributes: ``sent`` (commands written), ``errors`` (port failures reported),
    ``connected``.
    """

    def __init__(self, port: str, baud: int = 115200,
                 servo_range_deg: tuple[float, float] = (0.0, 120.0), zero_deg: float = 60.0,
                 max_rate_hz: float = 50.0, retry_s: float = 1.0,
                 clock: Callable[[], float] = time.monotonic) -> None:
        low, high = servo_range_deg
        if not low < high:
            raise ValueError(f"servo_range_deg must be (low, high) with low < high, "
                             f"got {servo_range_deg}")
        if not (isinstance(baud, int) and baud > 0):
            raise ValueError(f"baud must be a positive integer, got {baud!r}")
        if not max_rate_hz > 0:
            raise ValueError(f"max_rate_hz must be positive, got {max_rate_hz}")
        self.port, self.baud, self.low, self.high = port, baud, float(low), float(high)
        self.zero_deg, self.interval, self.retry_s = zero_deg, 1.0 / max_rate_hz, retry_s
        self.clock = clock
        self.serial: serial.Serial | None = None
        self.sent = self.errors = 0
        self._last_sent: dict[int, float] = {}
        self._last_time = -math.inf
        self._pending: list[float] | None = None
        self._next_retry = -math.inf
        self._open()

    @property
    def connected(self) -> bool:
        return self.serial is not None

    def servo_degrees(self, angles: Sequence[float] | np.ndarray) -> list[float]:
        """Servo angles (degrees, one decimal, clamped) for joint angles in rad."""
        out = []
        for q in np.asarray(angles, dtype=np.float64).ravel():
            degrees = self.zero_deg + math.degrees(q) if math.isfinite(q) else self.zero_deg
            out.append(round(min(max(degrees, self.low), self.high), 1))
        return out

    def _open(self) -> None:
        import serial

        self._next_retry = self.clock() + self.retry_s
        try:
            self.serial = serial.Serial(self.port, self.baud, timeout=0, write_timeout=0.1)
        except (OSError, ValueError, serial.SerialException) as err:
            self.serial = None
            self.errors += 1
            log.warning("servo port %s cannot be opened (%s); retrying every %.1f s",
                        self.port, err, self.retry_s)
            return
        self._last_sent.clear()  # the controller may have restarted: send everything again
        log.info("servo port %s open at %d baud", self.port, self.baud)

    def _lose(self, connection: serial.Serial, err: Exception) -> None:
        self.errors += 1
        log.warning("servo port %s lost (%s); retrying every %.1f s", self.port, err,
                    self.retry_s)
        import serial

        # The port is gone already: closing it is best effort.
        with contextlib.suppress(OSError, serial.SerialException, *_TTY_ERRORS):
            connection.close()
        self.serial = None
        self._next_retry = self.clock() + self.retry_s

    def send(self, angles: Sequence[float] | np.ndarray) -> bool:
        """Command joint angles (rad, one per joint). Returns True if a line was written
        now; False if it was held back (rate limit, or the port is down: it is kept as
        pending and goes out when possible). Never raises for a port failure."""
        self._pending = self.servo_degrees(angles)
        now = self.clock()
        if now - self._last_time < self.interval:
            return False
        return self.flush()

    def flush(self) -> bool:
        """Write the pending command now, whatever the rate limit. True if written."""
        import serial

        if self._pending is None:
            return False
        if self.serial is None:
            if self.clock() < self._next_retry:
                return False
            self._open()
            if self.serial is None:
                return False
        lines = [format_command(j + 1, d) for j, d in enumerate(self._pending)
                 if self._last_sent.get(j) != d]
        try:
            if lines:
                self.serial.write(b"".join(lines))
                self.serial.flush()
        except (OSError, serial.SerialException, *_TTY_ERRORS) as err:
            self._lose(self.serial, err)
            return False
        self._last_sent.update(enumerate(self._pending))
        self.sent += len(lines)
        self._last_time, self._pending = self.clock(), None
        return bool(lines)

    def close(self) -> None:
        """Send the last pending command (if the port is up) and close the port."""
        if self.serial is not None:
            self.flush()
        if self.serial is not None:
            self.serial.close()
            self.serial = None

    def __enter__(self) -> ServoBridge:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
