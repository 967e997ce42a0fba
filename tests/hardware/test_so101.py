"""SO101Bus against the emulated Feetech bus: the bytes on the wire, the calibration's steps,
and the safety rules (range, step limit, ramp, hold, torque off whatever stops the run)."""

import io
import itertools
import json
import logging
import math
import random

import pytest

from imimic_gym.hardware import (
    CalibrationError,
    CalibrationMismatchError,
    PortLostError,
    PortUnavailableError,
    ServosNotAnsweringError,
    SO101Bus,
    StartOutOfRangeError,
    load_calibration,
)
from tests.hardware.bus_emulator import (
    PING,
    READ,
    SYNC_WRITE,
    TORQUE,
    WRITE,
    FeetechBusEmulator,
    Packet,
)

STEP_LIMIT = 45  # 4 degrees * 4095 / 360 = 45.5 steps: whole steps only
IDS = {"shoulder_pan": 1, "shoulder_lift": 2, "elbow_flex": 3, "wrist_flex": 4,
       "wrist_roll": 5, "gripper": 6}


def open_bus(emulator, calibration, **options) -> SO101Bus:
    """A bus on the emulator. The answer timeout is generous (a busy machine may be slow to
    schedule the emulator's thread); only tests of silence wait it out."""
    return SO101Bus(emulator.port, calibration, **{"timeout_s": 0.5, **options})


def goals_received(emulator, count: int) -> list[dict[int, int]]:
    """The emulator's Goal_Position writes once ``count`` have arrived (SYNC_WRITE has no
    answer, so the bridge does not wait for it)."""
    assert emulator.wait_for(lambda: len(emulator.goal_writes()) >= count), \
        f"{len(emulator.goal_writes())} goal writes arrived, {count} expected"
    return emulator.goal_writes()


def torque_writes(packets: list[Packet], value: int) -> list[Packet]:
    return [p for p in packets if p.instruction == WRITE and p.params == bytes((TORQUE, value))]


def test_connect_reads_everything_before_any_write(emulator, calibration) -> None:
    emulator.set_present("elbow_flex", 2900)
    with open_bus(emulator, calibration) as bus:
        packets = list(emulator.received)
        assert [(p.servo_id, p.instruction) for p in packets[:6]] == \
            [(i, PING) for i in range(1, 7)]
        reads = [(p.servo_id, p.params[0], p.params[1]) for p in packets[6:24]]
        assert all(p.instruction == READ for p in packets[6:24])
        assert reads == [(i, address, size) for i in range(1, 7)
                         for address, size in ((9, 4), (31, 2), (56, 2))]
        assert not any(p.is_write for p in packets[:24])
        # Then: hold every servo where it stands, and only then torque on.
        assert packets[24].instruction == SYNC_WRITE
        assert packets[24].sync_values() == {1: 2025, 2: 2006, 3: 2900, 4: 2053, 5: 2045,
                                             6: 2775}
        assert torque_writes(packets[25:], 1) == packets[25:] and len(packets) == 31
        assert [emulator.register(i, TORQUE) for i in range(1, 7)] == [1] * 6
        assert bus.start_raw["elbow_flex"] == 2900
        assert bus.last_goal()["elbow_flex"] == pytest.approx((2900 - 1975.5) * 360 / 4095)


def test_known_targets_arrive_as_lerobots_steps(emulator, calibration) -> None:
    targets = {"shoulder_pan": 30.0, "shoulder_lift": 0.0, "elbow_flex": -10.0,
               "wrist_flex": 12.0, "wrist_roll": 19.5, "gripper": 25.0}
    with open_bus(emulator, calibration, max_step_deg=360.0) as bus:
        sent = bus.send(targets)
        goal = goals_received(emulator, 2)[-1]
    # Hand-computed in test_calibration: 2366, 1861, 2402; shoulder_lift's mid of 612..3401
    # is 2006.5; wrist_flex 12 * 11.375 + 2053.5 = 2190; wrist_roll 19.5 * 11.375 + 2045 =
    # 2266.8125.
    assert goal == {1: 2366, 2: 2006, 3: 1861, 4: 2190, 5: 2266, 6: 2402}
    for name, value in sent.items():
        assert calibration.to_raw(name, value) in (goal[IDS[name]], goal[IDS[name]] - 1)
        assert abs(value - targets[name]) <= (360 / 4095 if name != "gripper" else 100 / 1491)


def test_targets_are_clamped_to_the_calibrated_range(emulator, calibration) -> None:
    with open_bus(emulator, calibration, max_step_deg=360.0) as bus:
        sent = bus.send({"shoulder_pan.pos": 170.0, "elbow_flex.pos": -170.0,
                         "gripper.pos": 150.0, "wrist_roll.pos": 1e308,
                         "wrist_flex.pos": -1e308})
        goal = goals_received(emulator, 2)[-1]
    assert (goal[1], goal[3], goal[6], goal[5], goal[4]) == (3292, 881, 3521, 3983, 898)
    assert sent["gripper"] == 100.0
    assert sent["shoulder_pan"] == pytest.approx((3292 - 2025) * 360 / 4095)


def test_ramp_from_the_present_position_at_most_one_step_per_send(emulator,
                                                                  calibration) -> None:
    emulator.set_present("elbow_flex", 2900)
    with open_bus(emulator, calibration) as bus:
        for _ in range(25):
            bus.send({"shoulder_pan": 90.0, "elbow_flex": 0.0})
        goals = goals_received(emulator, 26)
    pan = [g[1] for g in goals]
    elbow = [g[3] for g in goals]
    # 90 degrees is step 3048 (1023.75 + 2025); from 2025, 45 steps a send: 23 sends.
    assert pan[:3] == [2025, 2070, 2115]
    assert pan[22:] == [3015, 3048, 3048, 3048]
    # 0 degrees is step 1975 (mid 1975.5); from 2900 down, 45 a send.
    assert elbow[:3] == [2900, 2855, 2810]
    assert elbow[20:] == [2000, 1975, 1975, 1975, 1975, 1975]
    assert all(g[2] == 2006 for g in goals)  # untouched joints keep their goal


def test_trust_zero_and_nan_hold_the_last_goal(emulator, calibration) -> None:
    with open_bus(emulator, calibration, max_step_deg=360.0) as bus:
        first = bus.send({"shoulder_pan": 10.0, "gripper": 50.0})
        assert bus.send({"shoulder_pan": -40.0, "gripper": 0.0}, trust=0.0) == first
        assert bus.send({"shoulder_pan": -40.0}, trust=math.nan) == first
        held = bus.send({"shoulder_pan": math.nan, "gripper": math.inf, "elbow_flex": 5.0})
        goals = goals_received(emulator, 5)
    assert goals[2] == goals[3] == goals[1]  # re-sent, unchanged
    assert held["shoulder_pan"] == first["shoulder_pan"] and held["gripper"] == first["gripper"]
    assert goals[4][3] == int(5 * 4095 / 360 + 1975.5) and goals[4][1] == goals[1][1]


def test_unknown_joints_are_refused_before_sending(emulator, calibration) -> None:
    with open_bus(emulator, calibration) as bus:
        with pytest.raises(ValueError, match="unknown joint 'elbow'; the SO-101's are "
                                             "shoulder_pan, "):
            bus.send({"elbow": 3.0})
        assert len(emulator.goal_writes()) == 1


def test_safety_invariant_under_wild_targets(emulator, calibration) -> None:
    """Whatever arrives: goals inside the range, steps of at most the limit, ever."""
    rng = random.Random(37)
    wild = [math.nan, math.inf, -math.inf, 1e12, -1e12, 1e308, -1e308]
    with open_bus(emulator, calibration) as bus:
        for _ in range(150):
            targets = {name: rng.choice(wild) if rng.random() < 0.1 else rng.uniform(-400, 400)
                       for name in IDS if rng.random() < 0.8}
            bus.send(targets, trust=rng.choice([0.0, 0.3, 1.0, 1.0]))
        goals = goals_received(emulator, 151)
    assert len(goals) == 151
    for name, servo_id in IDS.items():
        motor = calibration.motors[name]
        track = [g[servo_id] for g in goals]
        assert all(motor.range_min <= raw <= motor.range_max for raw in track), name
        steps = [abs(b - a) for a, b in itertools.pairwise(track)]
        assert max(steps) == STEP_LIMIT, name  # reached, never passed


def test_close_releases_every_servo_once(emulator, calibration) -> None:
    bus = open_bus(emulator, calibration)
    bus.connect()
    bus.send({"wrist_flex": 3.0})
    goals_received(emulator, 2)
    bus.close()
    bus.close()
    released = torque_writes(emulator.received, 0)
    assert [p.servo_id for p in released] == [1, 2, 3, 4, 5, 6]
    assert emulator.received[-6:] == released
    assert [emulator.register(i, TORQUE) for i in range(1, 7)] == [0] * 6
    assert not bus.connected


def test_an_exception_inside_with_releases_the_torque(emulator, calibration) -> None:
    with pytest.raises(RuntimeError, match="pose lost"), open_bus(emulator, calibration) as bus:
        bus.send({"shoulder_pan": 1.0})
        raise RuntimeError("pose lost")
    assert emulator.received[-6:] == torque_writes(emulator.received, 0)
    assert [emulator.register(i, TORQUE) for i in range(1, 7)] == [0] * 6


def test_ctrl_c_in_the_sending_loop_releases_the_torque(emulator, calibration) -> None:
    with pytest.raises(KeyboardInterrupt), open_bus(emulator, calibration) as bus:
        for frame in range(10):
            bus.send({"shoulder_lift": -float(frame)})
            if frame == 3:
                raise KeyboardInterrupt
    last = emulator.received[-1]
    assert (last.servo_id, last.instruction, last.params) == (6, WRITE, bytes((TORQUE, 0)))
    assert emulator.received[-6:] == torque_writes(emulator.received, 0)
    assert len(emulator.goal_writes()) == 5  # the hold at connect, then frames 0..3


def test_hold_leaves_the_torque_on(emulator, calibration) -> None:
    with open_bus(emulator, calibration, on_exit="hold") as bus:
        bus.send({"gripper": 40.0})
    goals_received(emulator, 2)
    assert torque_writes(emulator.received, 0) == []
    assert [emulator.register(i, TORQUE) for i in range(1, 7)] == [1] * 6


def test_a_silent_port_is_named_and_gets_no_write(calibration) -> None:
    with FeetechBusEmulator(calibration, silent=True) as emulator:
        bus = open_bus(emulator, calibration, tries=1, timeout_s=0.1)
        with pytest.raises(ServosNotAnsweringError,
                           match=rf"{emulator.port}: no servo answered \(ids 1, 2, 3, 4, 5, "
                                 r"6\) at 1000000 baud: is the arm powered"):
            bus.connect()
        assert [p.instruction for p in emulator.received] == [PING] * 6
        assert emulator.writes() == [] and emulator.errors == []
        assert not bus.connected
        bus.close()
        assert emulator.writes() == []


def test_missing_servos_are_named_and_get_no_write(calibration) -> None:
    with FeetechBusEmulator(calibration, missing_ids=(4, 5)) as emulator:
        with pytest.raises(ServosNotAnsweringError,
                           match=r"no answer from servo id\(s\) 4 \(wrist_flex\), "
                                 r"5 \(wrist_roll\)$") as caught:
            open_bus(emulator, calibration, tries=1).connect()
        assert caught.value.missing == ["wrist_flex", "wrist_roll"]
        assert emulator.writes() == [] and emulator.errors == []


def test_a_port_that_cannot_open_is_named(emulator, tmp_path, calibration) -> None:
    port = str(tmp_path / "ttyACM9")  # the arm is on emulator.port, not here
    with pytest.raises(PortUnavailableError, match=f"{port}: cannot open the SO-101 bus"):
        SO101Bus(port, calibration).connect()
    assert emulator.received == []


def test_a_malformed_calibration_stops_before_the_bus(emulator, tmp_path) -> None:
    path = tmp_path / "bad.json"
    path.write_text(json.dumps({"shoulder_pan": {}}))
    with pytest.raises(CalibrationError, match=r"bad\.json: missing motor"):
        SO101Bus(emulator.port, load_calibration(path))
    assert emulator.received == []


def test_a_calibration_of_another_arm_is_refused_without_writing(calibration,
                                                                 tmp_path) -> None:
    with FeetechBusEmulator(calibration) as emulator:
        emulator.set_register(3, 11, 3100)  # the arm's elbow_flex range ends at 3100
        with pytest.raises(CalibrationMismatchError,
                           match=r"servo 3 \(elbow_flex\) holds range 881..3100, homing offset "
                                 r"1105; the calibration \(.*my_follower.json\) says "
                                 r"881..3070, 1105"):
            open_bus(emulator, calibration).connect()
        assert emulator.writes() == [] and emulator.errors == []


def test_a_joint_far_outside_its_range_is_refused_without_writing(calibration) -> None:
    with FeetechBusEmulator(calibration) as emulator:
        emulator.set_present("wrist_flex", 898 - 100)
        with pytest.raises(StartOutOfRangeError, match="wrist_flex stands at step 798, 100 "
                                                       "steps outside its calibrated range"):
            open_bus(emulator, calibration).connect()
        assert emulator.writes() == []
        # Within one step of the range: connect, the first goal is the range's end.
        emulator.set_present("wrist_flex", 898 - 20)
        with open_bus(emulator, calibration):
            assert goals_received(emulator, 1)[0][4] == 898
        assert emulator.errors == []


def test_dry_run_prints_the_packets_and_opens_nothing(tmp_path, calibration) -> None:
    log = io.StringIO()
    with SO101Bus(str(tmp_path / "no-such-port"), calibration, dry_run=log) as bus:
        sent = bus.send({"shoulder_pan": 30.0})
    lines = log.getvalue().splitlines()
    assert lines[0] == ("dry run: no port opened; present positions taken as the middle of "
                        "each range")
    assert lines[1].startswith("ff ff fe 16 83 2a 02 01 e9 07 ")  # 2025 = 0x07e9
    assert lines[1].endswith("SYNC_WRITE Goal_Position: shoulder_pan(1)=2025, "
                             "shoulder_lift(2)=2006, elbow_flex(3)=1975, wrist_flex(4)=2053, "
                             "wrist_roll(5)=2045, gripper(6)=2775")
    assert lines[2] == "ff ff 01 04 03 28 01 ce  WRITE shoulder_pan(1) Torque_Enable = 1"
    assert "SYNC_WRITE Goal_Position: shoulder_pan(1)=2070," in lines[8]
    assert lines[9:] == [f"{line.split('  ')[0]}  WRITE {name}({i}) Torque_Enable = 0"
                         for line, (name, i) in zip(lines[9:], IDS.items(), strict=True)]
    assert sent["shoulder_pan"] == pytest.approx(45 * 360 / 4095)


def test_dry_run_true_prints_to_stdout(capsys, calibration) -> None:
    with SO101Bus("/dev/ttyNOWHERE", calibration, dry_run=True) as bus:
        bus.send({"gripper": 0.0})
    out = capsys.readouterr().out
    assert out.count("Torque_Enable = 1") == 6 and out.count("Torque_Enable = 0") == 6


def test_a_vanished_port_raises_on_send_and_close_only_logs(emulator, calibration,
                                                            caplog) -> None:
    bus = open_bus(emulator, calibration)
    bus.connect()
    emulator.unplug()
    with pytest.raises(PortLostError, match=f"{emulator.port}: the SO-101 bus failed"):
        for _ in range(50):  # the pty may take a write or two before it reports the loss
            bus.send({"shoulder_pan": 5.0})
    with caplog.at_level(logging.WARNING):
        bus.close()
    assert "torque could not be released" in caplog.text
    bus.close()


def test_bad_settings_are_named(calibration) -> None:
    with pytest.raises(ValueError, match="on_exit must be 'torque_off' or 'hold', got 'off'"):
        SO101Bus("/dev/null", calibration, on_exit="off")
    with pytest.raises(ValueError, match=r"max_step_deg must be finite and at least one step "
                                         r"\(0\.088 degrees\), got 0\.05"):
        SO101Bus("/dev/null", calibration, max_step_deg=0.05)
    for bad in (math.nan, math.inf, -4.0):
        with pytest.raises(ValueError, match=f"max_step_deg must be finite.*got {bad}"):
            SO101Bus("/dev/null", calibration, max_step_deg=bad)
    assert SO101Bus("/dev/null", calibration, on_exit="torque-off").on_exit == "torque_off"
