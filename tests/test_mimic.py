"""`imimic mimic` on a recorded synthetic clip: real OpenCV files, real MuJoCo, real DON."""

import csv
import json
import math
import os
import re
import signal
import subprocess
import sys

import cv2
import gymnasium as gym
import numpy as np
import pytest

from imimic_gym.cli import main
from imimic_gym.clips.cache import load_clip
from imimic_gym.clips.scenarios import get_scenario
from imimic_gym.clips.video import VideoFormatError, stream_video
from imimic_gym.clips.video_writer import write_video
from imimic_gym.estimators.pose.planar import human_joint_ranges
from imimic_gym.metrics import angle_rmse_deg
from imimic_gym.mimic import MimicLog, run_mimic
from imimic_gym.servo import ServoBridge
from tests.processes import DUMPS_STACKS, poll_until, stop, stream_live, wait_for_exit


def read_csv(path) -> list[dict[str, str]]:
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def test_mimic_video_writes_the_video_plot_and_csv(servo_clip, servo_mp4, tmp_path) -> None:
    out = tmp_path / "out"
    # The servo is filmed from above with its zero mark pointing up the image.
    assert main(["mimic", "--video", str(servo_mp4), "--estimator", "don",
                 "--reference-direction", "90", "--out", str(out)]) == 0
    video = cv2.VideoCapture(str(out / "mimic.mp4"))
    try:
        assert int(video.get(cv2.CAP_PROP_FRAME_COUNT)) == 90
        assert int(video.get(cv2.CAP_PROP_FRAME_WIDTH)) == 640
    finally:
        video.release()
    assert cv2.imread(str(out / "angles.png")) is not None
    rows = read_csv(out / "mimic.csv")
    assert list(rows[0]) == ["time_s", "frame", "angle_rad", "omega_rad_s", "torque_nm", "eta",
                             "predicted", "robot_rad", "latency_ms"]
    assert len(rows) == 90 and float(rows[30]["time_s"]) == pytest.approx(1.0)
    estimate = np.array([float(r["angle_rad"]) for r in rows])
    robot = np.array([float(r["robot_rad"]) for r in rows])
    truth = servo_clip.truth.angles[:, 0]
    # DON on the decoded file, then the servo robot following it: measured 0.74 and 1.39
    # deg on clip seed 0 (issue 40: about 2x).
    assert angle_rmse_deg(estimate[15:], truth[15:]) < 1.5
    assert angle_rmse_deg(robot[15:], truth[15:]) < 2.8
    assert all(0.0 <= float(r["eta"]) <= 1.0 for r in rows)
    summary = json.loads((out / "mimic.json").read_text())
    assert summary["frames"] == 90 and summary["ended"] == "end of footage"
    assert summary["frames_per_s"] > 0 and summary["skipped_frames"] == 0


def test_a_video_shorter_than_dons_window_is_named(servo_clip, tmp_path, capsys) -> None:
    path = write_video(tmp_path / "short.mp4", servo_clip.frames[:7], servo_clip.fps)
    message = r"short\.mp4 has 7 frames, fewer than the 11 that DON \(window 10\) needs"
    clip = stream_video(path)
    with pytest.raises(VideoFormatError, match=message):
        run_mimic(clip, tmp_path / "out", progress=False)
    assert clip.frames.reader.capture is None
    # The command says it in one line, no traceback, and exits with 2.
    assert main(["mimic", "--video", str(path), "--estimator", "don",
                 "--out", str(tmp_path / "out")]) == 2
    assert re.search(message, capsys.readouterr().err)


def test_a_one_frame_video_is_one_line_from_the_command(servo_clip, tmp_path, capsys) -> None:
    """The pose model reads a frame alone, but a run steps from a frame to the next."""
    path = write_video(tmp_path / "one.mp4", servo_clip.frames[:1], servo_clip.fps)
    assert main(["mimic", "--video", str(path), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert err.splitlines() == [f"imimic mimic: {path} has 1 frames, fewer than the 2 that "
                                "one step (from a frame to the next) needs"]


def test_a_missing_video_is_one_line_from_the_command(tmp_path, capsys) -> None:
    assert main(["mimic", "--video", str(tmp_path / "gone.mp4")]) == 2
    err = capsys.readouterr().err
    assert "cannot open video" in err and "gone.mp4: no such file" in err


def test_a_file_that_is_no_video_is_one_line_without_ffmpegs_own(tmp_path) -> None:
    """FFmpeg's log lines ("moov atom not found") and OpenCV's warnings stay out of the
    one-line error (they reach file descriptor 2 directly, hence a subprocess)."""
    (tmp_path / "notes.mp4").write_text("not a video\n")
    done = subprocess.run([sys.executable, "-m", "imimic_gym.cli", "mimic", "--video",
                           str(tmp_path / "notes.mp4"), "--out", str(tmp_path / "out")],
                          capture_output=True, text=True, timeout=120,
                          env={**os.environ, "MUJOCO_GL": "egl"})
    assert done.returncode == 2
    assert done.stderr.splitlines() == [f"imimic mimic: cannot open video {tmp_path}/notes.mp4: "
                                        "OpenCV cannot decode it (not a video, or an "
                                        "unsupported codec)"]


def test_more_links_than_don_follows_is_refused() -> None:
    with pytest.raises(SystemExit, match="don follows 1 to 3 moving links; --links 4"):
        main(["mimic", "--video", "x.mp4", "--estimator", "don", "--links", "4"])


def test_a_file_holding_fewer_frames_than_it_reports_says_so(truncated_avi,
                                                             tmp_path) -> None:
    summary = run_mimic(stream_video(truncated_avi), tmp_path / "out", progress=False)
    assert 11 <= summary["frames"] < 30
    assert summary["ended"].startswith(f"footage ended early: {summary['frames']} of the 30 ")


def test_a_cut_run_that_ends_early_counts_the_frames_asked_for(truncated_avi,
                                                                tmp_path) -> None:
    summary = run_mimic(stream_video(truncated_avi, max_frames=20), tmp_path / "out",
                        progress=False)
    assert summary["ended"].startswith(f"footage ended early: {summary['frames']} of the 20 "
                                       "frames asked for")


def test_an_intact_file_whose_container_counts_more_frames_ends_cleanly(edit_listed_mp4,
                                                                        tmp_path,
                                                                        capsys) -> None:
    """An edit list drops frames the container counts (30 reported, 24 decode): no
    "ended early", and the progress bar ends full at the frames that exist."""
    clip = stream_video(edit_listed_mp4, reference_direction=math.pi / 2)
    assert len(clip) == 30
    summary = run_mimic(clip, tmp_path / "out")
    assert summary["ended"] == "end of footage" and summary["frames"] == 24
    bar = capsys.readouterr().err.split("\r")[-1]
    assert "24/24" in bar and "/30" not in bar


def test_a_run_cut_to_a_length_says_so(servo_mp4, tmp_path) -> None:
    clip = stream_video(servo_mp4, max_frames=20)
    summary = run_mimic(clip, tmp_path / "out", progress=False)
    assert summary["frames"] == 20 and summary["ended"] == "stopped at the 20 frames asked for"


def test_a_stream_that_ends_early_keeps_everything_written(tmp_path) -> None:
    # An MJPEG stream reports no length, like a camera: the run ends when frames stop.
    frames = [cv2.imencode(".jpg", np.full((48, 64, 3), 10 * i, np.uint8))[1].tobytes()
              for i in range(14)]
    (tmp_path / "feed.mjpeg").write_bytes(b"".join(frames))
    clip = stream_video(tmp_path / "feed.mjpeg", fps=25.0)
    assert not clip.frames.length_known
    summary = run_mimic(clip, tmp_path / "out", progress=False)
    assert summary["frames"] == 14 and summary["ended"] == "end of footage"
    assert len(read_csv(tmp_path / "out" / "mimic.csv")) == 14
    assert clip.frames.reader.capture is None


def test_a_live_source_runs_until_it_stops(servo_mp4, tmp_path) -> None:
    # A URL is opened as a live source (like a network camera): no length, no rewinding;
    # when frames stop coming the run ends as a camera that disappeared. Its frames are
    # all there at once, so the ones the run falls behind on (the start-up, at least) are
    # passed over, as a camera's would be, and counted.
    clip = stream_video(f"file://{servo_mp4}", reference_direction=math.pi / 2)
    assert clip.meta["source"] == "camera" and not clip.frames.length_known
    summary = run_mimic(clip, tmp_path, progress=False)
    assert summary["ended"] == "camera stopped"
    assert summary["frames"] + summary["frames_passed_over"] == 90
    rows = read_csv(tmp_path / "mimic.csv")
    assert len(rows) == summary["frames"]
    # time_s is the stream's: a frame passed over leaves its gap (whole frames, in order).
    steps = np.diff([float(row["time_s"]) for row in rows]) * clip.fps
    assert np.all(np.abs(steps - np.round(steps)) < 0.01) and np.all(np.round(steps) >= 1)
    assert round(float(rows[-1]["time_s"]) * clip.fps) <= 89
    assert 0.0 <= summary["behind_stream_ms_median"] <= summary["behind_stream_ms_max"]
    assert clip.frames.reader.capture is None


def test_two_links_are_copied_from_a_video_file(tmp_path) -> None:
    spec = get_scenario("chain-2", seed=0)
    source = load_clip(spec, progress=False)
    write_video(tmp_path / "chain.mp4", source.frames, source.fps)
    clip = stream_video(tmp_path / "chain.mp4", n_links=2,
                        reference_direction=spec.reference_direction,
                        joint_ranges=spec.joint_ranges)
    summary = run_mimic(clip, tmp_path / "out", progress=False)
    rows = read_csv(tmp_path / "out" / "mimic.csv")
    assert summary["frames"] == len(rows) == 150 and clip.frames.reader.capture is None
    angles = np.array([[float(r["angle_rad1"]), float(r["angle_rad2"])] for r in rows])
    # From an mp4 (compression noise on the differences), shoulder found from the video:
    # measured 0.79 and 1.75 deg on clip seed 0 (issue 40: about 2x).
    for joint, bound in enumerate((1.6, 3.5)):
        assert angle_rmse_deg(angles[15:, joint], source.truth.angles[15:, joint]) < bound


class InterruptingServo:
    """Stands in for the user pressing Ctrl-C: the 20th joint command raises
    KeyboardInterrupt inside the loop, where a real SIGINT would land."""

    def __init__(self) -> None:
        self.sent = self.errors = 0

    def send(self, command) -> None:
        self.sent += 1
        if self.sent == 20:
            raise KeyboardInterrupt

    def close(self) -> None:
        pass


def test_ctrl_c_stops_cleanly_and_keeps_the_outputs(servo_mp4, tmp_path) -> None:
    clip = stream_video(servo_mp4, reference_direction=math.pi / 2)
    summary = run_mimic(clip, tmp_path, servo=InterruptingServo(), progress=False)
    assert summary["ended"] == "stopped by Ctrl-C" and summary["frames"] == 19
    assert len(read_csv(tmp_path / "mimic.csv")) == 19
    video = cv2.VideoCapture(str(tmp_path / "mimic.mp4"))
    try:
        assert int(video.get(cv2.CAP_PROP_FRAME_COUNT)) == 19  # a finished, readable file
    finally:
        video.release()
    assert cv2.imread(str(tmp_path / "angles.png")) is not None
    assert clip.frames.reader.capture is None


def test_mimic_drives_a_servo_through_a_pseudo_terminal(servo_mp4, tmp_path) -> None:
    controller, device = os.openpty()
    try:
        clip = stream_video(servo_mp4, reference_direction=math.pi / 2, max_frames=30)
        # A rate limit above the video's 30 fps: every new command goes out.
        servo = ServoBridge(os.ttyname(device), max_rate_hz=1000)
        summary = run_mimic(clip, tmp_path, servo=servo, progress=False)
        os.set_blocking(controller, False)
        lines = os.read(controller, 65536).decode().splitlines()
    finally:
        os.close(controller)
        os.close(device)
    assert summary["servo_errors"] == 0 and len(lines) == summary["servo_commands_sent"] > 5
    commanded = [float(r["robot_rad"]) for r in read_csv(tmp_path / "mimic.csv")]
    degrees = [float(line.split()[1]) for line in lines]
    assert all(line.startswith("J1 ") for line in lines)
    assert all(0.0 <= d <= 120.0 for d in degrees)
    # The servo follows the same target as the simulated robot (60 = joint angle 0): measured
    # 0.39 deg apart on the last frame (issue 40: about 2x, plus the 0.05 of the 0.1 deg
    # the line is rounded to).
    assert abs(degrees[-1] - 60 - math.degrees(commanded[-1])) < 0.85


def test_help_lists_mimic_and_its_options(capsys) -> None:
    with pytest.raises(SystemExit):
        main(["mimic", "--help"])
    text = capsys.readouterr().out
    for option in ("--video", "--camera", "--estimator", "--links", "--serial", "--baud",
                   "--reference-direction", "--joint-range"):
        assert option in text


def test_the_command_drives_a_servo_with_its_range(servo_mp4, tmp_path) -> None:
    controller, device = os.openpty()
    try:
        # --serial paces the file at its own 30 fps; one second of it is enough here.
        assert main(["mimic", "--video", str(servo_mp4), "--estimator", "don",
                     "--reference-direction", "90",
                     "--max-seconds", "1", "--serial", os.ttyname(device), "--baud", "57600",
                     "--servo-range", "10", "100", "--out", str(tmp_path)]) == 0
        os.set_blocking(controller, False)
        lines = os.read(controller, 65536).decode().splitlines()
    finally:
        os.close(controller)
        os.close(device)
    summary = json.loads((tmp_path / "mimic.json").read_text())
    assert summary["frames"] == 30 and summary["servo_commands_sent"] == len(lines) > 3
    assert all(10.0 <= float(line.split()[1]) <= 100.0 for line in lines)


def test_mimic_runs_the_cnn_on_a_recorded_person(tmp_path) -> None:
    from imimic_gym.clips import get_scenario, load_clip
    from imimic_gym.clips.video_writer import write_video

    clip = load_clip(get_scenario("default", seed=5, n_frames=40), progress=False)
    write_video(tmp_path / "person.mp4", clip.frames, clip.fps)
    out = tmp_path / "out"
    assert main(["mimic", "--video", str(tmp_path / "person.mp4"), "--estimator", "cnn",
                 "--joint-range", "0", "150", "--out", str(out)]) == 0
    rows = read_csv(out / "mimic.csv")
    estimate = np.array([float(r["angle_rad"]) for r in rows])
    # The shipped 1-link network on a decoded plain-wall clip: measured 5.2 deg on clip
    # seed 5 (issue 40: about 2x).
    assert len(rows) == 40 and angle_rmse_deg(estimate, clip.truth.angles[:, 0]) < 10.0
    with pytest.raises(SystemExit, match="--pivot is DON's"):
        main(["mimic", "--video", str(tmp_path / "person.mp4"), "--estimator", "cnn",
              "--pivot", "10", "10", "--out", str(tmp_path / "again")])


def test_by_default_mimic_finds_the_person_holds_when_they_leave_and_picks_them_up(
        tmp_path) -> None:
    from imimic_gym.clips import get_scenario, load_clip

    clip = load_clip(get_scenario("default", seed=5, n_frames=40), progress=False)
    empty = np.repeat(clip.frames[:1] * 0 + 235, 20, axis=0)  # the person walks out
    frames = np.concatenate([clip.frames[:20], empty, clip.frames[20:]])
    write_video(tmp_path / "person.mp4", frames, clip.fps)
    out = tmp_path / "out"
    assert main(["mimic", "--video", str(tmp_path / "person.mp4"), "--out", str(out)]) == 0
    rows = read_csv(out / "mimic.csv")
    eta = np.array([float(r["eta"]) for r in rows])
    robot = np.array([float(r["robot_rad"]) for r in rows])
    estimate = np.array([float(r["angle_rad"]) for r in rows])
    assert len(rows) == 60 and (eta[21:40] == 0.0).all()
    # Nobody in view: the estimate is held, so the robot settles and stays.
    assert np.ptp(estimate[21:40]) == 0.0 and np.ptp(robot[30:40]) < math.radians(1.0)
    # Back in view: read again, and the forearm followed, roughly: the model reads our
    # small mannequin in a compressed video some 20 degrees off on the median frame
    # (the uncompressed clip's accuracy is tests/estimators/pose/test_planar.py's).
    assert (eta[45:] > 0.5).mean() > 0.8
    error = np.degrees(np.abs(estimate[45:] - clip.truth.angles[25:, 0]))
    # measured 27.8 deg, the robot's travel 197 deg
    assert np.median(error) < 30.0 and np.ptp(robot[40:]) > math.radians(10.0)
    summary = json.loads((out / "mimic.json").read_text())
    assert summary["estimator"] == "pose" and summary["frames_without_reading"] >= 20


def test_the_writer_thread_keeps_what_was_written_and_hands_back_its_errors(tmp_path) -> None:
    """`write_behind`: a run cut short (Ctrl-C) still leaves a playable file of the
    frames made so far; a frame the writer cannot take is an error in the caller."""
    import cv2

    from imimic_gym.mimic import write_behind

    def frames(n: int, stop: BaseException | None = None):
        for i in range(n):
            yield np.full((32, 48, 3), 10 * i, dtype=np.uint8)
        if stop is not None:
            raise stop

    with pytest.raises(KeyboardInterrupt):
        write_behind(tmp_path / "cut.mp4", frames(12, KeyboardInterrupt()), 30.0, depth=2)
    capture = cv2.VideoCapture(str(tmp_path / "cut.mp4"))
    try:
        assert int(capture.get(cv2.CAP_PROP_FRAME_COUNT)) == 12
    finally:
        capture.release()

    def mixed():
        yield np.zeros((32, 48, 3), np.uint8)
        for _ in range(20):
            yield np.zeros((16, 16, 3), np.uint8)  # a different size: the writer refuses

    with pytest.raises(ValueError, match="earlier frames"):
        write_behind(tmp_path / "bad.mp4", mixed(), 30.0, depth=2)


def test_a_ctrl_c_before_the_first_frame_does_not_hang_the_writer(tmp_path) -> None:
    """Ctrl-C while the first frame is being made: `write_behind` hands the KeyboardInterrupt
    back at once (the writer, finding no frames, must not wait for a second end marker)."""
    import threading

    from imimic_gym.mimic import write_behind

    def no_frame():
        raise KeyboardInterrupt
        yield

    raised: list[BaseException] = []

    def run() -> None:
        try:
            write_behind(tmp_path / "none.mp4", no_frame(), 30.0)
        except BaseException as error:
            raised.append(error)

    caller = threading.Thread(target=run, daemon=True)
    caller.start()
    caller.join(timeout=30)
    assert not caller.is_alive(), "write_behind hung after a Ctrl-C before the first frame"
    assert len(raised) == 1 and isinstance(raised[0], KeyboardInterrupt)


def test_a_second_ctrl_c_while_the_video_is_finished_is_ignored(tmp_path, monkeypatch) -> None:
    """A Ctrl-C that lands while the writer finishes the file (here: sent by the writer
    itself once it has every frame) neither stops `write_behind` nor leaves a file that
    does not play."""
    import imimic_gym.mimic as mimic

    real_write = mimic.write_video

    def write_then_interrupt(path, frames, fps):
        def frames_then_signal():
            yield from frames
            os.kill(os.getpid(), signal.SIGINT)  # the main thread is in the join now
        return real_write(path, frames_then_signal(), fps)

    monkeypatch.setattr(mimic, "write_video", write_then_interrupt)
    frames = (np.full((32, 48, 3), 10 * i, dtype=np.uint8) for i in range(12))
    mimic.write_behind(tmp_path / "done.mp4", frames, 30.0, depth=2)
    capture = cv2.VideoCapture(str(tmp_path / "done.mp4"))
    try:
        assert int(capture.get(cv2.CAP_PROP_FRAME_COUNT)) == 12
    finally:
        capture.release()


def test_a_writer_that_fails_ends_the_frames_and_gives_ctrl_c_back(tmp_path) -> None:
    """The writer refuses a frame while the frames' generator holds Ctrl-C across its
    yield (as `mimic_frames` does): `write_behind` raises the writer's error and closes the
    generator, so Ctrl-C is Python's own again."""
    from imimic_gym.interrupts import ctrl_c_held
    from imimic_gym.mimic import write_behind

    closed = []

    def held_frames():
        try:
            for size in [32] + [16] * 20:  # a different size: the writer refuses it
                with ctrl_c_held():
                    yield np.zeros((size, 48, 3), np.uint8)
        finally:
            closed.append(True)

    started_with = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        with pytest.raises(ValueError, match="earlier frames"):
            write_behind(tmp_path / "bad.mp4", held_frames(), 30.0, depth=2)
        assert closed == [True]
        assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
    finally:
        signal.signal(signal.SIGINT, started_with)


def test_a_writer_that_never_finishes_is_an_error_not_a_hang(tmp_path, monkeypatch) -> None:
    """A writer stuck after its last frame (a hung disk, say): `write_behind` gives up
    after ``finish_within`` seconds with a TimeoutError naming the file."""
    import threading

    import imimic_gym.mimic as mimic

    release = threading.Event()

    def stuck_write(path, frames, fps):
        for _ in frames:
            pass
        release.wait(60)

    monkeypatch.setattr(mimic, "write_video", stuck_write)
    frames = (np.zeros((32, 48, 3), np.uint8) for _ in range(5))
    try:
        with pytest.raises(TimeoutError, match=r"stuck\.mp4.*did not finish within 0\.2 s"):
            mimic.write_behind(tmp_path / "stuck.mp4", frames, 30.0, depth=2,
                               finish_within=0.2)
    finally:
        release.set()


class InterruptedRender(gym.Wrapper):
    """Stands in for the user pressing Ctrl-C while a frame is being drawn (the costliest
    part of a frame): the ``at``-th ``render`` raises KeyboardInterrupt."""

    def __init__(self, env, at: int) -> None:
        super().__init__(env)
        self.calls, self.at = 0, at

    def render(self):
        self.calls += 1
        if self.calls == self.at:
            raise KeyboardInterrupt
        return self.env.render()


class InterruptedLog(MimicLog):
    """Stands in for Ctrl-C landing just after the log took a frame, before its picture:
    the ``at``-th frame logged raises KeyboardInterrupt once logged."""

    at = 7

    def on_step(self, env, step) -> None:
        super().on_step(env, step)
        if len(self.time) == self.at:
            raise KeyboardInterrupt


@pytest.mark.parametrize("where", ["drawing", "logging"])
def test_a_frame_whose_drawing_ctrl_c_stops_is_in_no_output(servo_mp4, tmp_path,
                                                           where: str) -> None:
    """A Ctrl-C while frame 7 is drawn, or just after it was logged: the log, the CSV and
    the video all end at frame 6."""
    from imimic_gym.controllers import EstimateTarget, PDController
    from imimic_gym.mimic import csv_header, mimic_frames, write_behind
    from imimic_gym.wrappers import RegistryObservation

    clip = stream_video(servo_mp4, reference_direction=math.pi / 2)
    scene = gym.make("ImitateVideo-v0", clip=clip, render_mode="rgb_array")
    env = RegistryObservation(InterruptedRender(scene, at=7) if where == "drawing" else scene,
                              "don", keep_frame=False)
    log = MimicLog(fps=clip.fps) if where == "drawing" else InterruptedLog(fps=clip.fps)
    with (tmp_path / "mimic.csv").open("w", newline="") as table:
        rows = csv.writer(table)
        rows.writerow(csv_header(1))
        with pytest.raises(KeyboardInterrupt):
            write_behind(tmp_path / "mimic.mp4",
                         mimic_frames(env, PDController(env, EstimateTarget(env)), log, rows),
                         clip.fps)
    env.close()
    clip.frames.close()
    video = cv2.VideoCapture(str(tmp_path / "mimic.mp4"))
    try:
        assert int(video.get(cv2.CAP_PROP_FRAME_COUNT)) == 6
    finally:
        video.release()
    assert len(log.time) == len(read_csv(tmp_path / "mimic.csv")) == 6


def ctrl_c_mimic_at_the_tenth_frame(source: list[str], out) -> None:
    """`imimic mimic` on ``source`` (its options: --video F ..., --camera URL), a real
    SIGINT once ten frames are in mimic.csv: exit code 130 as the other commands, and the
    video, the CSV and the JSON all hold the same frames (of the 90 there are)."""
    run = subprocess.Popen([sys.executable, "-m", "imimic_gym.cli", "mimic", *source, "--out",
                            str(out)], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                           text=True, env={**os.environ, "MUJOCO_GL": "egl", **DUMPS_STACKS})
    try:
        poll_until(lambda: (out / "mimic.csv").exists() and len(read_csv(out / "mimic.csv")) >= 10,
                   run, 120, "ten frames in mimic.csv")
        run.send_signal(signal.SIGINT)
        _, err = wait_for_exit(run, 120)
    finally:
        stop(run)
    assert run.returncode == 130, err[-2000:]
    summary = json.loads((out / "mimic.json").read_text())
    assert summary["ended"] == "stopped by Ctrl-C" and 10 <= summary["frames"] < 90
    video = cv2.VideoCapture(str(out / "mimic.mp4"))
    try:
        assert int(video.get(cv2.CAP_PROP_FRAME_COUNT)) == summary["frames"]
    finally:
        video.release()
    assert len(read_csv(out / "mimic.csv")) == summary["frames"]


@pytest.mark.parametrize("estimator", ["don", "pose"])  # pose: a model thread reads ahead
def test_ctrl_c_stops_the_command_with_130_and_as_many_frames_in_video_as_in_json(
        servo_mp4, tmp_path, estimator: str) -> None:
    """A real SIGINT to `imimic mimic --video` mid-run (played at its own speed, 3 s)."""
    ctrl_c_mimic_at_the_tenth_frame(["--video", str(servo_mp4), "--estimator", estimator,
                                     "--realtime"], tmp_path / "out")


def test_ctrl_c_on_a_live_stream_stops_with_130_and_as_many_frames_in_video_as_in_json(
        servo_mp4, tmp_path) -> None:
    """A real SIGINT to `imimic mimic --camera URL` reading a live stream (ffmpeg plays
    the clip at its own speed over local TCP): the next frame is read and estimated
    while each picture is drawn, and a Ctrl-C landing anywhere in that still ends the
    run as on a file."""
    player, url = stream_live(servo_mp4)
    try:
        ctrl_c_mimic_at_the_tenth_frame(["--camera", url], tmp_path / "out")
    finally:
        stop(player)


def without_latency(path) -> list[list[str]]:
    with open(path, newline="") as table:
        rows = list(csv.reader(table))
    column = rows[0].index("latency_ms")
    return [row[:column] + row[column + 1:] for row in rows]


def mimic_stack(path, out, robot: str | None, log: MimicLog, ahead: bool, threads: list,
                interrupt_at: int | None = None) -> None:
    """`run_mimic`'s stack on a file, with or without estimating ahead (``ahead``: the pose
    model reads each next frame on its thread; else each frame when it is observed):
    mimic.csv and mimic.mp4 into ``out``. ``interrupt_at``: the render that Ctrl-C stops
    (`InterruptedRender`). ``threads`` gets the pose model's thread, if it started one."""
    from imimic_gym.controllers import EstimateTarget, PDController
    from imimic_gym.envs.imitate_video import imitate_env
    from imimic_gym.mimic import csv_header, mimic_frames, spatial_csv_header, write_behind
    from imimic_gym.wrappers import RegistryObservation, RenderAhead

    clip = stream_video(path, joint_ranges=human_joint_ranges(1))
    scene = (gym.make("ImitateVideo-v0", clip=clip, render_mode="rgb_array") if robot is None
             else gym.make("ImitateVideo3D-v0", clip=clip, robot=robot,
                           render_mode="rgb_array"))
    below = (RenderAhead(scene) if interrupt_at is None
             else InterruptedRender(RenderAhead(scene), at=interrupt_at))
    env = RegistryObservation(below, "pose" if robot is None else "pose3d", keep_frame=False,
                              estimate_ahead=ahead)
    model = env.estimator.model if robot is None else env.estimator.spatial.model
    spec = None if robot is None else imitate_env(env).arm
    out.mkdir()
    try:
        with (out / "mimic.csv").open("w", newline="", buffering=1) as table:
            rows = csv.writer(table)
            rows.writerow(csv_header(1) if spec is None else spatial_csv_header(spec.joint_names))
            controller = PDController(env, EstimateTarget(env))
            write_behind(out / "mimic.mp4", mimic_frames(env, controller, log, rows, robot=spec),
                         clip.fps)
    finally:
        threads.extend([model.thread] if model.thread is not None else [])
        env.close()
        clip.frames.close()


@pytest.mark.parametrize("robot", [None, "so101"])
def test_estimating_ahead_leaves_every_output_as_it_was(person_mp4, tmp_path,
                                                        robot: str | None) -> None:
    """`run_mimic` on a file reads each next frame with the pose model while the frame
    before is worked on: mimic.csv (but for its latency) and mimic.mp4 are byte for byte
    those of the same stack reading each frame when it comes."""
    plain, ahead = tmp_path / "plain", tmp_path / "ahead"
    threads: list = []
    mimic_stack(person_mp4, plain, robot, MimicLog(fps=30.0), ahead=False, threads=threads)
    assert threads == []  # the model read each frame on the caller's thread
    summary = run_mimic(stream_video(person_mp4, joint_ranges=human_joint_ranges(1)), ahead,
                        estimator="pose" if robot is None else "pose3d", progress=False,
                        robot=robot)
    assert summary["frames"] == 20 and summary["frames_without_reading"] < 10
    assert without_latency(ahead / "mimic.csv") == without_latency(plain / "mimic.csv")
    assert (ahead / "mimic.mp4").read_bytes() == (plain / "mimic.mp4").read_bytes()


def test_ctrl_c_while_estimating_ahead_keeps_the_finished_frames_and_stops_the_thread(
        person_mp4, tmp_path) -> None:
    """Ctrl-C while frame 7 is drawn (frame 8 being read on the model's thread): the log,
    the CSV and the video end at frame 6, and closing the env stops the thread."""
    log, threads = MimicLog(fps=30.0), []
    with pytest.raises(KeyboardInterrupt):
        mimic_stack(person_mp4, tmp_path / "cut", None, log, ahead=True, threads=threads,
                    interrupt_at=7)
    assert len(threads) == 1 and not threads[0].is_alive()  # close joined it
    video = cv2.VideoCapture(str(tmp_path / "cut" / "mimic.mp4"))
    try:
        assert int(video.get(cv2.CAP_PROP_FRAME_COUNT)) == 6
    finally:
        video.release()
    assert len(log.time) == len(read_csv(tmp_path / "cut" / "mimic.csv")) == 6


def test_mimic_so101_writes_the_named_columns(person_mp4, tmp_path) -> None:
    """`imimic mimic --robot so101` on a short rendered clip: mimic.csv has the issue's
    columns (the elbow's flexion in degrees, the upper arm's and forearm's unit directions
    in the camera frame, the joint targets named as LeRobot names them) and the arm read,
    one row a frame, every value finite and in range."""
    from imimic_gym.hardware.calibration import SO101_JOINTS
    from imimic_gym.robots import SO101Spec

    assert main(["mimic", "--video", str(person_mp4), "--robot", "so101", "--out",
                 str(tmp_path)]) == 0
    with (tmp_path / "mimic.csv").open(newline="") as table:
        header = next(csv.reader(table))
    directions = ["upper_x", "upper_y", "upper_z", "fore_x", "fore_y", "fore_z"]
    assert header == ["time_s", "frame", "eta", "elbow_flexion_deg", *directions,
                      *(f"{name}.pos" for name in SO101_JOINTS), "latency_ms", "arm"]
    rows = read_csv(tmp_path / "mimic.csv")
    assert [int(row["frame"]) for row in rows] == list(range(20))
    read = [row for row in rows if float(row["eta"]) > 0]
    assert len(read) >= 10
    spec = SO101Spec()
    for row in rows:
        values = {name: float(row[name]) for name in header if name != "arm"}
        assert all(math.isfinite(v) for v in values.values())
        assert 0.0 <= values["elbow_flexion_deg"] <= 180.0
        for bone in ("upper", "fore"):
            length = math.hypot(*(values[f"{bone}_{axis}"] for axis in "xyz"))
            assert length == pytest.approx(1.0, abs=1e-4)
        for name, (lo, hi) in zip(SO101_JOINTS[:5], spec.joint_ranges[:5], strict=True):
            assert math.radians(values[f"{name}.pos"]) == pytest.approx(
                min(max(math.radians(values[f"{name}.pos"]), lo), hi), abs=1e-4)
        assert 0.0 <= values["gripper.pos"] <= 100.0
        assert row["arm"] in ("left", "right")
    # The rendered person moves their left arm, the label's side (Clip.meta["arm_side"]).
    assert {row["arm"] for row in read} == {"left"}
    # Footage of an unknown camera: the lift assumed a typical one, and says which.
    assert json.loads((tmp_path / "mimic.json").read_text())["camera_fov_deg"] == 60.0


def test_mimic_so101_reads_the_arm_through_the_camera_given_by_fov(person_mp4,
                                                                     tmp_path) -> None:
    """``--fov`` is the camera the 3-D lift reads through: mimic.json names it, and the
    same footage through a narrow and a wide camera gives other arm directions (the
    perspective of each bone's ray) from the same keypoints."""
    directions: dict[str, np.ndarray] = {}
    for fov in ("30", "120"):
        out = tmp_path / fov
        assert main(["mimic", "--video", str(person_mp4), "--robot", "so101", "--fov", fov,
                     "--out", str(out)]) == 0
        assert json.loads((out / "mimic.json").read_text())["camera_fov_deg"] == float(fov)
        rows = [row for row in read_csv(out / "mimic.csv") if float(row["eta"]) > 0]
        assert len(rows) >= 10
        directions[fov] = np.array([[float(row[f"{bone}_{axis}"]) for bone in ("upper", "fore")
                                     for axis in "xyz"] for row in rows])
    assert directions["30"].shape == directions["120"].shape
    assert np.abs(directions["30"] - directions["120"]).max() > 0.05
