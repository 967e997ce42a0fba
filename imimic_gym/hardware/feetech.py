"""The Feetech SCS/STS serial protocol (protocol 0, the STS3215 of the SO-100/SO-101 arms):
packets to build, status packets to parse.

Instruction packet (host to servos), status packet (a servo's answer)::

    0xFF 0xFF id length instruction params... checksum
    0xFF 0xFF id length error       params... checksum

``length`` = len(params) + 2; ``checksum`` = ~(id + length + instruction-or-error +
sum(params)) & 0xFF. Multi-byte registers are little-endian. A SYNC_WRITE goes to the
broadcast id 0xFE and gets no answer; PING, READ and WRITE to one id get one status packet.
Register addresses and widths are the STS3215's (the table LeRobot's Feetech bus uses).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from enum import IntEnum

__all__ = [
    "BROADCAST_ID",
    "GOAL_POSITION",
    "HOMING_OFFSET",
    "MAX_POSITION_LIMIT",
    "MAX_SERVO_ID",
    "MIN_POSITION_LIMIT",
    "PRESENT_POSITION",
    "TORQUE_ENABLE",
    "BusError",
    "ChecksumError",
    "Instruction",
    "MalformedPacketError",
    "ProtocolError",
    "Register",
    "ServoError",
    "StatusPacket",
    "StatusTimeoutError",
    "WrongIdError",
    "checksum",
    "decode_sign_magnitude",
    "describe_packet",
    "encode_value",
    "instruction_packet",
    "ping_packet",
    "read_packet",
    "read_status",
    "sync_write_packet",
    "write_packet",
]

BROADCAST_ID = 0xFE
MAX_SERVO_ID = 0xFD  # 0xFE is the broadcast id, 0xFF part of the header
_HEADER = b"\xff\xff"


class Instruction(IntEnum):
    PING = 0x01
    READ = 0x02
    WRITE = 0x03
    SYNC_WRITE = 0x83


@dataclass(frozen=True)
class Register:
    """One entry of the STS3215 control table: ``address`` and ``size`` in bytes."""

    name: str
    address: int
    size: int


MIN_POSITION_LIMIT = Register("Min_Position_Limit", 9, 2)    # EEPROM, steps
MAX_POSITION_LIMIT = Register("Max_Position_Limit", 11, 2)   # EEPROM, steps
HOMING_OFFSET = Register("Homing_Offset", 31, 2)             # EEPROM, sign-magnitude, bit 11
TORQUE_ENABLE = Register("Torque_Enable", 40, 1)             # 0 off, 1 on
GOAL_POSITION = Register("Goal_Position", 42, 2)             # steps, 0..4095
PRESENT_POSITION = Register("Present_Position", 56, 2)       # steps, read-only
_REGISTERS = {r.address: r for r in (MIN_POSITION_LIMIT, MAX_POSITION_LIMIT, HOMING_OFFSET,
                                     TORQUE_ENABLE, GOAL_POSITION, PRESENT_POSITION)}

# The status packet's error byte (Feetech's STS manual; SCServo SDK's ERRBIT_*).
_ERROR_BITS = {0x01: "input voltage", 0x02: "angle sensor", 0x04: "overheat",
               0x08: "overcurrent", 0x20: "overload"}


class BusError(RuntimeError):
    """The servo bus failed: a port, a servo that does not answer, a bad packet."""


class StatusTimeoutError(BusError):
    """No complete status packet arrived in time."""


class ProtocolError(BusError):
    """Bytes arrived that are not the status packet asked for."""


class ChecksumError(ProtocolError):
    """A status packet whose checksum does not match its bytes."""


class WrongIdError(ProtocolError):
    """A status packet from another servo than the one asked."""


class MalformedPacketError(ProtocolError):
    """A packet whose length field cannot be right."""


class ServoError(BusError):
    """A servo answered with error bits set (overload, overheat, ...)."""


def checksum(body: bytes) -> int:
    """The checksum of ``body`` = id, length, instruction-or-error and params."""
    return ~sum(body) & 0xFF


def instruction_packet(servo_id: int, instruction: int, params: bytes = b"") -> bytes:
    """The complete packet, header to checksum."""
    if not 0 <= servo_id <= BROADCAST_ID:
        raise ValueError(f"servo id must be 0..254, got {servo_id}")
    if len(params) > 253:
        raise ValueError(f"at most 253 parameter bytes fit a packet, got {len(params)}")
    body = bytes((servo_id, len(params) + 2, instruction)) + params
    return _HEADER + body + bytes((checksum(body),))


def encode_value(value: int, size: int) -> bytes:
    """``value`` as ``size`` little-endian bytes (unsigned)."""
    if not 0 <= value < 1 << (8 * size):
        raise ValueError(f"{value} does not fit {size} unsigned byte(s)")
    return value.to_bytes(size, "little")


def decode_sign_magnitude(value: int, sign_bit: int) -> int:
    """Feetech's signed registers: bit ``sign_bit`` is the sign, the bits below the size."""
    magnitude = value & ((1 << sign_bit) - 1)
    return -magnitude if value >> sign_bit & 1 else magnitude


def ping_packet(servo_id: int) -> bytes:
    return instruction_packet(servo_id, Instruction.PING)


def read_packet(servo_id: int, address: int, size: int) -> bytes:
    """Ask ``servo_id`` for ``size`` bytes from ``address``."""
    return instruction_packet(servo_id, Instruction.READ, bytes((address, size)))


def write_packet(servo_id: int, register: Register, value: int) -> bytes:
    """Set ``register`` of ``servo_id`` to ``value`` (unsigned); the servo answers."""
    return instruction_packet(servo_id, Instruction.WRITE,
                              bytes((register.address,)) + encode_value(value, register.size))


def sync_write_packet(register: Register, values: Mapping[int, int]) -> bytes:
    """Set ``register`` on every servo of ``values`` (id -> unsigned value) in one packet,
    broadcast, unanswered."""
    params = bytearray((register.address, register.size))
    for servo_id, value in values.items():
        params.append(servo_id)
        params += encode_value(value, register.size)
    return instruction_packet(BROADCAST_ID, Instruction.SYNC_WRITE, bytes(params))


@dataclass(frozen=True)
class StatusPacket:
    """A servo's answer: its id, the error byte (0 = fine) and the data read, if any."""

    servo_id: int
    error: int
    params: bytes

    def value(self) -> int:
        """The params as one little-endian unsigned integer."""
        return int.from_bytes(self.params, "little")


def read_status(read: Callable[[int], bytes], expected_id: int, timeout_s: float,
                clock: Callable[[], float] = time.monotonic) -> StatusPacket:
    """Read one status packet from a byte stream.

    Args:
        read: returns up to n bytes, or fewer (none) when nothing came within its own short
            timeout (pyserial's ``Serial.read``).
        expected_id: the servo asked.
        timeout_s: seconds for the whole packet.

    Bytes before the 0xFF 0xFF header are skipped (a half-duplex line's noise).

    Raises:
        StatusTimeoutError: no complete packet in ``timeout_s``.
        MalformedPacketError: a length field below 2.
        ChecksumError: the checksum does not match.
        WrongIdError: a packet from another id.
        ServoError: the servo reports error bits.
    """
    deadline = clock() + timeout_s
    buffer = bytearray()

    def fill(size: int) -> None:
        while len(buffer) < size:
            chunk = read(size - len(buffer))
            if chunk:
                buffer.extend(chunk)
            elif clock() > deadline:
                raise StatusTimeoutError(
                    f"servo {expected_id} did not answer within {timeout_s * 1000:.0f} ms "
                    f"(got {len(buffer)} byte(s): {buffer.hex(' ') or 'none'})")

    fill(2)
    while buffer[:2] != _HEADER:  # resynchronise one byte at a time
        del buffer[0]
        fill(2)
    fill(4)
    while buffer[2] == 0xFF:  # 0xFF is no id: a third header byte
        del buffer[0]
        fill(4)
    servo_id, length = buffer[2], buffer[3]
    if length < 2:
        raise MalformedPacketError(f"status packet from id {servo_id} has length {length} "
                                   f"(at least 2): {buffer.hex(' ')}")
    fill(4 + length)
    body = bytes(buffer[2:3 + length])
    if checksum(body) != buffer[3 + length]:
        raise ChecksumError(f"status packet {buffer.hex(' ')}: checksum "
                            f"{buffer[3 + length]:#04x}, expected {checksum(body):#04x}")
    if servo_id != expected_id:
        raise WrongIdError(f"servo {servo_id} answered where servo {expected_id} was asked")
    status = StatusPacket(servo_id, body[2], body[3:])
    if status.error:
        flags = [name for bit, name in _ERROR_BITS.items() if status.error & bit]
        raise ServoError(f"servo {servo_id} reports error {status.error:#04x} "
                         f"({', '.join(flags) or 'unknown bits'})")
    return status


def describe_packet(packet: bytes, names: Mapping[int, str] | None = None) -> str:
    """One line: the packet's bytes in hex, then what it asks. ``names`` maps ids to
    motor names for the reader; unknown registers show their address."""
    names = names or {}

    def servo(servo_id: int) -> str:
        return f"{names[servo_id]}({servo_id})" if servo_id in names else f"id {servo_id}"

    def register(address: int) -> Register:
        return _REGISTERS.get(address, Register(f"address {address}", address, 0))

    servo_id, instruction, params = packet[2], packet[4], packet[5:-1]
    if instruction == Instruction.PING:
        meaning = f"PING {servo(servo_id)}"
    elif instruction == Instruction.READ:
        meaning = f"READ {servo(servo_id)} {register(params[0]).name} ({params[1]} bytes)"
    elif instruction == Instruction.WRITE:
        value = int.from_bytes(params[1:], "little")
        meaning = f"WRITE {servo(servo_id)} {register(params[0]).name} = {value}"
    elif instruction == Instruction.SYNC_WRITE:
        address, size = params[0], params[1]
        entries = [params[i:i + 1 + size] for i in range(2, len(params), 1 + size)]
        values = ", ".join(f"{servo(e[0])}={int.from_bytes(e[1:], 'little')}" for e in entries)
        meaning = f"SYNC_WRITE {register(address).name}: {values}"
    else:
        meaning = f"instruction {instruction:#04x} to {servo(servo_id)}"
    return f"{packet.hex(' ')}  {meaning}"
