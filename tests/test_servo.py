"""The servo bridge against a real pseudo-terminal pair: the test holds the controller's end."""

import math
import os
import select

import pytest

from imimic_gym.servo import ServoBridge, format_command


class FakeClock:
    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        return self.now


def read_all(fd: int) -> bytes:
    """Everything the bridge has written so far, from the controller's end."""
    data = b""
    while select.select([fd], [], [], 0.2)[0]:
        chunk = os.read(fd, 4096)
        if not chunk:
            break
        data += chunk
    return data


@pytest.fixture
def pty_pair():
    controller, device = os.openpty()
    yield controller, os.ttyname(device)
    for fd in (controller, device):
        try:
            os.close(fd)
        except OSError:
            pass


def test_commands_arrive_clamped_rate_limited_and_exact(pty_pair) -> None:
    controller, port = pty_pair
    clock = FakeClock()
    with ServoBridge(port, baud=115200, max_rate_hz=50, clock=clock) as bridge:
        assert bridge.connected
        assert bridge.send([math.radians(27.5)])          # 60 + 27.5
        clock.now = 0.005
        assert not bridge.send([math.radians(-10.0)])     # 5 ms later: held back
        clock.now = 0.030
        assert bridge.send([math.radians(-75.0)])         # below the servo's 0: clamped
        clock.now = 0.060
        assert bridge.send([math.radians(90.0)])          # above 120: clamped
        clock.now = 0.090
        assert not bridge.send([math.radians(61.0)])      # still 120 after clamping: unsent
        clock.now = 0.120
        assert bridge.send([math.radians(-12.34)])        # rounded to one decimal
        clock.now = 0.125
        bridge.send([float("nan")])                       # never sent as NaN: held at zero
    # close() flushed the pending command.
    assert read_all(controller) == b"J1 87.5\nJ1 0.0\nJ1 120.0\nJ1 47.7\nJ1 60.0\n"
    assert bridge.sent == 5 and bridge.errors == 0


def test_several_joints_are_numbered_from_one(pty_pair) -> None:
    controller, port = pty_pair
    bridge = ServoBridge(port, clock=FakeClock())
    bridge.send([0.0, math.radians(15.0)])
    bridge.close()
    assert read_all(controller) == format_command(1, 60.0) + format_command(2, 75.0)


def test_a_lost_port_is_reported_and_retried_never_raised(tmp_path, caplog) -> None:
    first_controller, first_device = os.openpty()
    link = tmp_path / "ttyServo"
    link.symlink_to(os.ttyname(first_device))
    clock = FakeClock()
    bridge = ServoBridge(str(link), retry_s=1.0, clock=clock)
    bridge.send([0.0])
    assert read_all(first_controller) == b"J1 60.0\n"

    # Unplugged: the controller's end goes away, writes fail with EIO.
    os.close(first_controller)
    clock.now = 0.1
    assert not bridge.send([math.radians(10.0)])
    assert not bridge.connected and bridge.errors == 1
    assert "servo port" in caplog.text and "lost" in caplog.text
    clock.now = 0.5
    assert not bridge.send([math.radians(20.0)])    # before the retry time: not even tried

    # Plugged back in (a new device behind the same name): the next retry reconnects and
    # sends the latest command.
    second_controller, second_device = os.openpty()
    link.unlink()
    link.symlink_to(os.ttyname(second_device))
    clock.now = 1.2
    assert bridge.send([math.radians(20.0)])
    assert bridge.connected
    assert read_all(second_controller) == b"J1 80.0\n"
    bridge.close()
    for fd in (first_device, second_controller, second_device):
        os.close(fd)


def test_a_port_that_does_not_exist_is_reported_not_raised(tmp_path, caplog) -> None:
    bridge = ServoBridge(str(tmp_path / "ttyNothing"), clock=FakeClock())
    assert not bridge.connected and bridge.errors == 1
    assert not bridge.send([0.0])
    assert "cannot be opened" in caplog.text
    bridge.close()


def test_bad_settings_are_named() -> None:
    with pytest.raises(ValueError, match=r"servo_range_deg must be \(low, high\)"):
        ServoBridge("/dev/null", servo_range_deg=(120.0, 0.0))
    with pytest.raises(ValueError, match="baud must be a positive integer, got 0"):
        ServoBridge("/dev/null", baud=0)
