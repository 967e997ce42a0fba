"""A Feetech STS3215 bus on a pseudo-terminal: six servos that parse every byte the bridge
sends, as the real ones would, and answer PING and READ with status packets.

Its packet parser is written apart from imimic_gym.hardware.feetech on purpose: an encoder
bug cannot hide behind the same bug in the decoder. Anything a real bus would not accept
(bytes outside a packet, a bad checksum or length, an unknown id or register, a write to
EEPROM) lands in ``errors``; tests assert it stays empty.
"""

from __future__ import annotations

import os
import select
import threading
import time
import tty
from collections.abc import Callable, Iterable
from dataclasses import dataclass

from imimic_gym.hardware.calibration import SO101Calibration

PING, READ, WRITE, SYNC_WRITE = 0x01, 0x02, 0x03, 0x83
BROADCAST = 0xFE
# The STS3215 control table entries the bridge may touch: address -> size in bytes
# (LeRobot's src/lerobot/motors/feetech/tables.py).
REGISTERS = {3: 2, 9: 2, 11: 2, 31: 2, 40: 1, 42: 2, 55: 1, 56: 2}
WRITABLE = {40, 42, 55}  # Torque_Enable, Goal_Position, Lock: RAM, never EEPROM
TORQUE, GOAL, PRESENT = 40, 42, 56
STS3215_MODEL = 777


def _sum_check(body: bytes) -> int:
    total = 0
    for byte in body:
        total += byte
    return 255 - (total % 256)


@dataclass(frozen=True)
class Packet:
    """One instruction packet as received: ``servo_id``, ``instruction``, ``params``."""

    servo_id: int
    instruction: int
    params: bytes

    @property
    def is_write(self) -> bool:
        return self.instruction in (WRITE, SYNC_WRITE)

    def sync_values(self) -> dict[int, int]:
        """A SYNC_WRITE's id -> value (little-endian)."""
        size = self.params[1]
        entries = [self.params[i:i + 1 + size] for i in range(2, len(self.params), 1 + size)]
        return {e[0]: int.from_bytes(e[1:], "little") for e in entries}


class FeetechBusEmulator:
    """Six STS3215 servos (ids from ``calibration``) behind a pty; ``port`` is its name.

    Args:
        calibration: ids, and the limits and homing offset the servos hold.
        silent: answer nothing (a powered-off arm, a wrong port).
        missing_ids: servos that answer nothing.
        follow_goal: Present_Position jumps to Goal_Position while the torque is on.
        deadline_s: the reader thread stops by itself after this long, whatever happens.
    """

    def __init__(self, calibration: SO101Calibration, *, silent: bool = False,
                 missing_ids: Iterable[int] = (), follow_goal: bool = True,
                 deadline_s: float = 20.0) -> None:
        self.controller, self.device = os.openpty()
        tty.setraw(self.device)
        self.port = os.ttyname(self.device)
        self.silent, self.missing_ids, self.follow_goal = silent, set(missing_ids), follow_goal
        self.ids = {name: m.id for name, m in calibration.motors.items()}
        self.memory: dict[int, bytearray] = {}
        for motor in calibration.motors.values():
            memory = bytearray(64)
            offset = abs(motor.homing_offset) | (0x800 if motor.homing_offset < 0 else 0)
            for address, value in ((3, STS3215_MODEL), (9, motor.range_min),
                                   (11, motor.range_max), (31, offset),
                                   (GOAL, (motor.range_min + motor.range_max) // 2),
                                   (PRESENT, (motor.range_min + motor.range_max) // 2)):
                memory[address:address + 2] = value.to_bytes(2, "little")
            self.memory[motor.id] = memory
        self.received: list[Packet] = []
        self.errors: list[str] = []
        self._changed = threading.Condition()
        self._stop = threading.Event()
        self._deadline = time.monotonic() + deadline_s
        self._thread = threading.Thread(target=self._serve, name="feetech-emulator", daemon=True)
        self._thread.start()

    # -- what tests read and set ----------------------------------------------------------

    def register(self, servo_id: int, address: int) -> int:
        size = REGISTERS[address]
        return int.from_bytes(self.memory[servo_id][address:address + size], "little")

    def set_register(self, servo_id: int, address: int, value: int) -> None:
        size = REGISTERS[address]
        self.memory[servo_id][address:address + size] = value.to_bytes(size, "little")

    def set_present(self, name: str, raw: int) -> None:
        """Put joint ``name`` at ``raw`` steps (goal too: the servo stands there)."""
        self.set_register(self.ids[name], PRESENT, raw)
        self.set_register(self.ids[name], GOAL, raw)

    def writes(self) -> list[Packet]:
        with self._changed:
            return [p for p in self.received if p.is_write]

    def goal_writes(self) -> list[dict[int, int]]:
        """Every SYNC_WRITE of Goal_Position in order, as id -> raw steps."""
        return [p.sync_values() for p in self.writes()
                if p.instruction == SYNC_WRITE and p.params[0] == GOAL]

    def wait_for(self, condition: Callable[[], bool], timeout_s: float = 2.0) -> bool:
        """Wait until ``condition()`` holds after a packet; False after ``timeout_s``."""
        with self._changed:
            return self._changed.wait_for(condition, timeout_s)

    def unplug(self) -> None:
        """The adapter goes away: the bridge's writes and reads fail from now on."""
        self._stop.set()
        self._thread.join(timeout=2.0)
        os.close(self.controller)
        self.controller = -1

    def close(self) -> None:
        self._stop.set()
        self._thread.join(timeout=2.0)
        for fd in (self.controller, self.device):
            if fd >= 0:
                os.close(fd)
        self.controller = self.device = -1

    def __enter__(self) -> FeetechBusEmulator:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # -- the bus --------------------------------------------------------------------------

    def _serve(self) -> None:
        buffer = bytearray()
        while not self._stop.is_set() and time.monotonic() < self._deadline:
            if not select.select([self.controller], [], [], 0.02)[0]:
                continue
            try:
                buffer += os.read(self.controller, 4096)
            except OSError:
                return
            while self._take_packet(buffer):
                pass

    def _fail(self, message: str, buffer: bytearray) -> bool:
        with self._changed:
            self.errors.append(message)
            buffer.clear()
            self._changed.notify_all()
        return False

    def _take_packet(self, buffer: bytearray) -> bool:
        """Parse and handle one packet from the front of ``buffer``; False if incomplete."""
        if buffer[:2] not in (b"", b"\xff", b"\xff\xff"):
            return self._fail(f"bytes outside a packet: {buffer.hex(' ')}", buffer)
        if len(buffer) < 4:
            return False
        length = buffer[3]
        if len(buffer) < 4 + length:
            return False
        packet_bytes = bytes(buffer[:4 + length])
        del buffer[:4 + length]
        body = packet_bytes[2:-1]
        if length < 2:
            return self._fail(f"length {length} below 2: {packet_bytes.hex(' ')}", buffer)
        if _sum_check(body) != packet_bytes[-1]:
            return self._fail(f"bad checksum: {packet_bytes.hex(' ')}", buffer)
        packet = Packet(body[0], body[2], body[3:])
        problem = self._check(packet)
        if problem:
            return self._fail(f"{problem}: {packet_bytes.hex(' ')}", buffer)
        absent = packet.servo_id in self.missing_ids
        with self._changed:
            self.received.append(packet)
            answer = None if absent else self._apply(packet)
            self._changed.notify_all()
        if answer is not None and not self.silent:
            status = bytes((packet.servo_id, len(answer) + 2, 0)) + answer
            os.write(self.controller, b"\xff\xff" + status + bytes((_sum_check(status),)))
        return True

    def _span_ok(self, address: int, size: int) -> bool:
        """Whether [address, address + size) is whole known registers."""
        end = address + size
        while address < end:
            if address not in REGISTERS:
                return False
            address += REGISTERS[address]
        return address == end

    def _check(self, packet: Packet) -> str:
        known = set(self.memory)
        if packet.instruction == SYNC_WRITE:
            if packet.servo_id != BROADCAST:
                return f"SYNC_WRITE to id {packet.servo_id}, not the broadcast id"
            if len(packet.params) < 2:
                return "SYNC_WRITE without address and size"
            address, size = packet.params[0], packet.params[1]
            if (len(packet.params) - 2) % (1 + size):
                return f"SYNC_WRITE params do not split into id + {size} bytes"
            if address not in WRITABLE or not self._span_ok(address, size):
                return f"SYNC_WRITE to register {address} ({size} bytes)"
            strangers = set(packet.sync_values()) - known
            return f"SYNC_WRITE to unknown id(s) {sorted(strangers)}" if strangers else ""
        if packet.servo_id not in known:
            return f"instruction {packet.instruction} to unknown id {packet.servo_id}"
        if packet.instruction == PING:
            return "" if not packet.params else "PING with parameters"
        if packet.instruction == READ:
            if len(packet.params) != 2 or not self._span_ok(*packet.params):
                return f"READ of {packet.params.hex(' ')}"
            return ""
        if packet.instruction == WRITE:
            if len(packet.params) < 2:
                return "WRITE without data"
            address, size = packet.params[0], len(packet.params) - 1
            if address not in WRITABLE or not self._span_ok(address, size):
                return f"WRITE to register {address} ({size} bytes)"
            return ""
        return f"unknown instruction {packet.instruction:#04x}"

    def _apply(self, packet: Packet) -> bytes | None:
        """Change the registers; the status packet's params, or None for no answer."""
        if packet.instruction == PING:
            return b""
        memory = self.memory.get(packet.servo_id)
        if packet.instruction == READ:
            assert memory is not None
            address, size = packet.params
            return bytes(memory[address:address + size])
        if packet.instruction == WRITE:
            assert memory is not None
            self._store(memory, packet.params[0], packet.params[1:])
            return b""
        for servo_id, value in packet.sync_values().items():
            if servo_id in self.missing_ids:
                continue
            self._store(self.memory[servo_id], packet.params[0],
                        value.to_bytes(packet.params[1], "little"))
        return None

    def _store(self, memory: bytearray, address: int, data: bytes) -> None:
        memory[address:address + len(data)] = data
        if self.follow_goal and memory[TORQUE] == 1:
            memory[PRESENT:PRESENT + 2] = memory[GOAL:GOAL + 2]
