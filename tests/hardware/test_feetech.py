"""Feetech packets against bytes computed by hand, and the status parser on byte streams."""

import pytest

from imimic_gym.hardware.feetech import (
    GOAL_POSITION,
    TORQUE_ENABLE,
    ChecksumError,
    Instruction,
    MalformedPacketError,
    ServoError,
    StatusTimeoutError,
    WrongIdError,
    checksum,
    decode_sign_magnitude,
    describe_packet,
    instruction_packet,
    ping_packet,
    read_packet,
    read_status,
    sync_write_packet,
    write_packet,
)


def test_the_manuals_examples() -> None:
    # Feetech's STS manual: ping servo 1; read its present position (2 bytes at 0x38);
    # write position 2048, time 0, speed 1000 from 0x2A.
    assert ping_packet(1) == bytes.fromhex("ff ff 01 02 01 fb")
    assert read_packet(1, 0x38, 2) == bytes.fromhex("ff ff 01 04 02 38 02 be")
    assert instruction_packet(1, Instruction.WRITE, bytes.fromhex("2a 00 08 00 00 e8 03")) \
        == bytes.fromhex("ff ff 01 09 03 2a 00 08 00 00 e8 03 d5")


def test_write_and_sync_write_by_hand() -> None:
    # id 3, length 4, WRITE, address 40, value 1: ~(3 + 4 + 3 + 40 + 1) = ~0x33 = 0xcc
    assert write_packet(3, TORQUE_ENABLE, 1) == bytes.fromhex("ff ff 03 04 03 28 01 cc")
    # Broadcast, length 10, SYNC_WRITE, address 42, 2 bytes each; id 1 -> 2048 (00 08),
    # id 2 -> 1000 (e8 03). Sum 254+10+131+42+2+1+0+8+2+232+3 = 685 = 0x2ad: ~0xad = 0x52
    assert sync_write_packet(GOAL_POSITION, {1: 2048, 2: 1000}) == bytes.fromhex(
        "ff ff fe 0a 83 2a 02 01 00 08 02 e8 03 52")
    assert checksum(bytes.fromhex("fe 0a 83 2a 02 01 00 08 02 e8 03")) == 0x52


def test_values_that_do_not_fit_are_refused() -> None:
    with pytest.raises(ValueError, match="65536 does not fit 2 unsigned byte"):
        sync_write_packet(GOAL_POSITION, {1: 65536})
    with pytest.raises(ValueError, match="-1 does not fit 2 unsigned byte"):
        write_packet(1, GOAL_POSITION, -1)
    with pytest.raises(ValueError, match=r"servo id must be 0\.\.254, got 255"):
        ping_packet(255)


def test_sign_magnitude() -> None:
    assert decode_sign_magnitude(1470 | 0x800, 11) == -1470
    assert decode_sign_magnitude(157, 11) == 157


class Stream:
    """Bytes arriving in chunks; an empty read is a read timeout."""

    def __init__(self, *chunks: bytes) -> None:
        self.chunks = list(chunks)

    def read(self, size: int) -> bytes:
        if not self.chunks:
            return b""
        chunk = self.chunks.pop(0)
        if len(chunk) > size:
            self.chunks.insert(0, chunk[size:])
        return chunk[:size]


class Clock:
    """Advances 10 ms per call: a read timeout takes time without sleeping."""

    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        self.now += 0.01
        return self.now


def status(*byte_values: int) -> bytes:
    return bytes(byte_values)


def test_a_status_packet_after_noise_and_split_across_reads() -> None:
    # Servo 1 answers Present_Position 2048: ~(1 + 4 + 0 + 0x00 + 0x08) = ~13 = 0xf2.
    stream = Stream(b"\x00\xff", b"\xff\xff\x01\x04", b"\x00\x00", b"\x08\xf2")
    answer = read_status(stream.read, 1, 0.1, Clock())
    assert (answer.servo_id, answer.error, answer.params, answer.value()) == (1, 0, b"\x00\x08",
                                                                               2048)


@pytest.mark.parametrize(("data", "error", "message"), [
    (b"", StatusTimeoutError, r"servo 1 did not answer within 100 ms \(got 0 byte\(s\): none\)"),
    (b"\xff\xff\x01\x04\x00", StatusTimeoutError, r"got 5 byte\(s\): ff ff 01 04 00"),
    (b"\xff\xff\x01\x04\x00\x00\x08\xf3", ChecksumError, "checksum 0xf3, expected 0xf2"),
    (b"\xff\xff\x02\x02\x00\xfb", WrongIdError, "servo 2 answered where servo 1 was asked"),
    (b"\xff\xff\x01\x01\x00", MalformedPacketError, "has length 1"),
    (b"\xff\xff\x01\x02\x24\xd8", ServoError, r"error 0x24 \(overheat, overload\)"),
])
def test_bad_answers_raise_their_own_error(data: bytes, error: type, message: str) -> None:
    with pytest.raises(error, match=message):
        read_status(Stream(data).read, 1, 0.1, Clock())


def test_describe_names_servos_and_registers() -> None:
    line = describe_packet(sync_write_packet(GOAL_POSITION, {1: 2048, 2: 1000}),
                           {1: "shoulder_pan", 2: "shoulder_lift"})
    assert line == ("ff ff fe 0a 83 2a 02 01 00 08 02 e8 03 52  SYNC_WRITE Goal_Position: "
                    "shoulder_pan(1)=2048, shoulder_lift(2)=1000")
    assert describe_packet(write_packet(3, TORQUE_ENABLE, 0)).endswith(
        "WRITE id 3 Torque_Enable = 0")
    assert describe_packet(read_packet(1, 56, 2)).endswith("READ id 1 Present_Position (2 bytes)")
