"""The emulator itself: it answers as a servo would and flags what a real bus would not take
(so the bridge's tests can trust an empty ``errors``)."""

import os
import select

import pytest

from tests.hardware.bus_emulator import FeetechBusEmulator


def answer(emulator: FeetechBusEmulator, size: int) -> bytes:
    """``size`` bytes from the bridge's end of the pty, or what came within 2 s."""
    data = b""
    while len(data) < size and select.select([emulator.device], [], [], 2.0)[0]:
        data += os.read(emulator.device, size - len(data))
    return data


def test_ping_and_read_are_answered_like_a_servo(calibration) -> None:
    with FeetechBusEmulator(calibration) as emulator:
        os.write(emulator.device, bytes.fromhex("ff ff 01 02 01 fb"))
        assert answer(emulator, 6) == bytes.fromhex("ff ff 01 02 00 fc")
        # READ Min_Position_Limit and Max_Position_Limit of servo 1: 758 (f6 02), 3292 (dc 0c);
        # checksum ~(1 + 6 + 0 + 0xf6 + 0x02 + 0xdc + 0x0c) = ~0x1e7 -> 0x18
        os.write(emulator.device, bytes.fromhex("ff ff 01 04 02 09 04 eb"))
        assert answer(emulator, 10) == bytes.fromhex("ff ff 01 06 00 f6 02 dc 0c 18")
        assert emulator.errors == []


@pytest.mark.parametrize(("packet", "error"), [
    ("ff ff 01 02 01 fa", "bad checksum"),
    ("ff ff 09 02 01 f3", "instruction 1 to unknown id 9"),
    ("ff ff 01 04 02 32 02 c4", "READ of 32 02"),                  # address 50: no register
    ("ff ff 01 04 02 38 01 bf", "READ of 38 01"),                  # half a register
    ("ff ff 01 05 03 09 00 00 ed", "WRITE to register 9"),         # EEPROM
    ("ff ff fe 06 83 2a 02 01 00 4b", "params do not split"),      # one byte short
    ("00 ff ff 01 02 01 fb", "bytes outside a packet"),
])
def test_what_a_bus_would_not_take_is_flagged(calibration, packet, error) -> None:
    with FeetechBusEmulator(calibration) as emulator:
        os.write(emulator.device, bytes.fromhex(packet))
        assert emulator.wait_for(lambda: bool(emulator.errors))
        assert error in emulator.errors[0]
        assert emulator.received == []
