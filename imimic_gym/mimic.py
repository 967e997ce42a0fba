"""`imimic mimic`: an estimator and a controller on recorded or live footage, driving the
simulated arm (and, through `ServoBridge`, a real servo arm), written out as it goes.

The pieces are the library's own: the footage is a streamed `Clip`
(`clips.video.stream_video`), the env is ``ImitateVideo-v0`` on that clip (no truth:
tracking reward 0), the estimator is added by its observation wrapper, the controller is
`PDController` on `EstimateTarget`, and the outputs are `write_video` and
`plot_tracking`. Nothing holds the whole stream: frames are rendered and written one by
one, the CSV is appended and flushed per frame, and only a few numbers per frame stay in
memory for the plot.

Outputs in ``out``: ``mimic.mp4`` (the footage with the estimate drawn on it by the
estimator wrapper's ``render``, beside the simulated robot), ``angles.png`` (estimated
vs robot angle), ``mimic.csv`` (one row a frame: ``time_s, frame, angle_rad,
omega_rad_s, torque_nm, eta, predicted, robot_rad, latency_ms`` with one column per joint
for the angle-like fields, suffixed 1..n; ``time_s`` is the frame's time in the footage,
a live stream's own from its first frame used, so frames passed over leave their gap)
and ``mimic.json`` (frames/s after the first
frame, latency, how the run ended). Ctrl-C, or a camera that disappears, ends the run
cleanly with all of them written up to that frame.

Latency is the wall time from asking the source for a frame to the joint command being
ready (reading, decoding, estimating, controlling; not the video rendering), so on a
live camera it is how far the robot's command trails the picture, less the camera's own
delay. A file is run for throughput instead: its frames are decoded ahead on a thread
(`clips.video.ReadAhead`, not counted), the robot view of each state starts drawing
before the estimator reads the frame (`wrappers.RenderAhead`, counted), and an estimator
with a ``prefetch`` hook (the pose estimators) reads each frame on a thread of its own
while the frame before is lifted, controlled, drawn and written (``estimate_ahead``,
`wrappers.EstimatorObservation`: only the wait for what is left of it counted), so that
the two cores share the work. A camera's or stream's frame is read when asked for and
nothing is drawn before the command; its next frame is read once the command is out and
read by the pose model while this frame's picture is drawn. Its frames that queued up
while the run started, or later because the loop went slower than the source, are passed
over (`clips.video.FrameStream.keep_live`), so the robot follows the picture of now:
mimic.json counts them (``frames_passed_over``) and says how long after each frame's
arrival its command was ready (``behind_stream_ms_median``, ``_max``: unlike the latency,
this counts a frame's wait in a queue).
"""

from __future__ import annotations

import csv
import math
import queue
import threading
import time
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, cast

import gymnasium as gym
import numpy as np

from imimic_gym.atomic import write_json
from imimic_gym.clips.video import require_frames
from imimic_gym.clips.video_writer import write_video
from imimic_gym.envs.imitate_video import imitate_env
from imimic_gym.estimators.registry import get_estimator
from imimic_gym.hardware.so101 import PortLostError as RobotLinkLost
from imimic_gym.interrupts import CTRL_C, ctrl_c_held, is_ctrl_c, unstoppable
from imimic_gym.rollout import Observer, Step, Trajectory, episode
from imimic_gym.wrappers import EstimatorObservation, RegistryObservation, RenderAhead
from imimic_gym.wrappers.spatial import RetargetedEstimator

__all__ = ["PREVIEW_HEIGHT", "CsvLog", "MimicLog", "ServoOut", "mimic_frames", "run_mimic",
           "write_behind"]

# Rows of mimic.mp4 for taller footage: drawing the robot and encoding a 3840x1080 side-by-
# side video cost a 1080p run more than reading and estimating the footage did.
PREVIEW_HEIGHT = 540


@dataclass
class MimicLog:
    """What `mimic_frames` measured, per frame. n joints; rad, rad/s, N m, ms. ``time``
    (s) is the frame's index over ``fps``; with a live source's ``clock``, its stream
    time from frame 0's, so the frames passed over (`FrameStream.keep_live`) keep their
    gap."""

    fps: float
    time: list[float] = field(default_factory=list)
    angles: list[np.ndarray] = field(default_factory=list)
    robot: list[np.ndarray] = field(default_factory=list)
    trust: list[float] = field(default_factory=list)
    predicted: list[bool] = field(default_factory=list)
    latency_ms: list[float] = field(default_factory=list)
    first_done: float | None = None  # perf_counter when the first frame was done
    last_done: float | None = None
    # A live source's stream clock (`FrameStream.clock`): frame index -> `StreamClock`.
    clock: Any = None
    # Per frame: (command ready, frame read), each less the frame's stream time (s); None
    # without a clock.
    stream_offsets: list[tuple[float, float] | None] = field(default_factory=list)
    _stream_zero: float | None = None  # stream time of frame 0 (s), from the first stamp
    _shift: float = 0.0  # time less frame / fps, from the last frame with a stamp (s)

    def on_step(self, env: gym.Env, step: Step) -> None:
        """Observer (`rollout.episode`): the estimate (``env.last_estimate``, an
        `EstimatorObservation`), the robot angle and the latency from asking for the frame
        to this call (the controller has answered; observers before this one, such as the
        servo's, count too). A live source's frame read ahead (``ahead_when_drawn``)
        counts from when it was asked of the source."""
        ahead = getattr(env, "frame_asked", None)
        asked = step.asked if ahead is None else min(step.asked, ahead)
        latency = 1000.0 * (time.perf_counter() - asked)
        estimate = cast(EstimatorObservation, env).last_estimate
        assert estimate is not None  # every observation sets it
        index = step.info["frame_index"]
        stamp = None if self.clock is None else self.clock(index)
        if stamp is not None:  # the stream's time: frames passed over leave their gap
            if self._stream_zero is None:
                self._stream_zero = stamp.stream_s - index / self.fps
            self._shift = stamp.stream_s - self._stream_zero - index / self.fps
        self.time.append(index / self.fps + self._shift)
        self.angles.append(estimate.angles.copy())
        self.robot.append(step.obs["qpos"].copy())
        self.trust.append(estimate.trust)
        self.predicted.append(estimate.predicted)
        self.latency_ms.append(latency)
        self.last_done = time.perf_counter()
        if self.first_done is None:
            self.first_done = self.last_done
        self.stream_offsets.append(None if stamp is None else (
            self.last_done - stamp.stream_s, stamp.read_at - stamp.stream_s))

    def truncate(self, frames: int) -> None:
        """Forget every frame after the first ``frames`` (those whose outputs were not all
        written; a Ctrl-C may cut `on_step` short, so the series may differ in length)."""
        for series in (self.time, self.angles, self.robot, self.trust, self.predicted,
                       self.latency_ms, self.stream_offsets):
            del series[frames:]
        if not self.time:
            self.first_done = self.last_done = None

    def behind_stream_ms(self) -> np.ndarray:
        """Per frame with a stream clock: how long after the frame could first have been
        read its command was ready (ms). A frame's earliest read is taken from the
        run's promptest read (the least read time less stream time; a source sending in
        real time), so a frame that waited in a queue counts its wait, which the
        latency does not. A lower bound if no frame of the run was read promptly."""
        offsets = np.asarray([o for o in self.stream_offsets if o is not None]).reshape(-1, 2)
        if not len(offsets):
            return np.zeros(0)
        return 1000.0 * (offsets[:, 0] - offsets[:, 1].min())

    def trajectory(self) -> Trajectory:
        """The run as a `Trajectory` whose target is the estimate (for `plot_tracking`)."""
        return Trajectory(time=np.asarray(self.time), target=np.asarray(self.angles),
                          robot=np.asarray(self.robot), reward=np.zeros(len(self.time)),
                          occlusion=np.zeros(len(self.time)))


def csv_header(n: int) -> list[str]:
    """mimic.csv's columns for ``n`` joints (angle-like ones suffixed 1..n when n > 1)."""
    def joints(name: str) -> list[str]:
        return [f"{name}{j + 1}" for j in range(n)] if n > 1 else [name]

    return ["time_s", "frame", *joints("angle_rad"), *joints("omega_rad_s"),
            *joints("torque_nm"), "eta", "predicted", *joints("robot_rad"), "latency_ms"]


class CsvLog:
    """Observer: one ``mimic.csv`` row a frame (`csv_header`) from ``log``'s last frame,
    flushed as written. Runs after ``log``."""

    def __init__(self, rows: Any, log: MimicLog) -> None:
        self.rows, self.log = rows, log

    def on_step(self, env: gym.Env, step: Step) -> None:
        estimate = cast(EstimatorObservation, env).last_estimate
        assert estimate is not None
        n = len(estimate.angles)
        self.rows.writerow([f"{self.log.time[-1]:.4f}", step.info["frame_index"],
                            *(f"{v:.6f}" for v in estimate.angles),
                            *(f"{v:.6f}" for v in estimate.omega),
                            *(f"{v:.6f}" for v in estimate.torque),
                            f"{estimate.trust:.4f}", int(estimate.predicted),
                            *(f"{v:.6f}" for v in step.obs["qpos"][:n]),
                            f"{self.log.latency_ms[-1]:.2f}"])


def spatial_csv_header(joint_names: Sequence[str]) -> list[str]:
    """mimic.csv's columns for a spatial robot (``--robot so101``): the arm read in 3-D
    (elbow flexion, degrees; the upper-arm and forearm unit directions in the camera
    frame, x right, y down, z away from the camera), the robot's joint targets named as
    LeRobot names them (``shoulder_pan.pos``: degrees; ``gripper.pos``: 0-100), the
    latency, and which of the person's arms the row reads (``arm``: their own "left" or
    "right"; the moving one unless ``--arm`` names it)."""
    return ["time_s", "frame", "eta", "elbow_flexion_deg", "upper_x", "upper_y", "upper_z",
            "fore_x", "fore_y", "fore_z", *(f"{name}.pos" for name in joint_names),
            "latency_ms", "arm"]


class SpatialCsvLog:
    """Observer: one ``mimic.csv`` row a frame (`spatial_csv_header`) for a spatial robot:
    the estimator's last `ArmPose` and the joint command the controller gave (the
    position servos' targets, what a real arm is sent), in LeRobot's units. Runs after
    ``log``."""

    def __init__(self, rows: Any, log: MimicLog, robot: Any) -> None:
        self.rows, self.log, self.robot = rows, log, robot
        self._inner: Any = None

    def on_step(self, env: gym.Env, step: Step) -> None:
        if self._inner is None:
            self._inner = imitate_env(env)
        pose = cast("RetargetedEstimator", cast(EstimatorObservation, env).estimator).last_pose
        targets = self.robot.to_lerobot(self._inner.action_to_command(step.action))
        estimate = cast(EstimatorObservation, env).last_estimate
        assert estimate is not None and pose is not None
        self.rows.writerow([f"{self.log.time[-1]:.4f}", step.info["frame_index"],
                            f"{estimate.trust:.4f}",
                            f"{math.degrees(pose.elbow_flexion):.3f}",
                            *(f"{v:.5f}" for v in pose.upper_arm),
                            *(f"{v:.5f}" for v in pose.forearm),
                            *(f"{targets[name]:.4f}" for name in self.robot.joint_names),
                            f"{self.log.latency_ms[-1]:.2f}", pose.side])


class BusOut:
    """Observer: each frame's joint command to a spatial robot's bus (an `SO101Bus`): the
    position servos' targets in LeRobot's units, with the estimate's trust (the bus holds
    on trust 0)."""

    def __init__(self, bus: Any, robot: Any) -> None:
        self.bus, self.robot = bus, robot
        self._inner: Any = None

    def on_step(self, env: gym.Env, step: Step) -> None:
        if self._inner is None:
            self._inner = imitate_env(env)
        estimate = cast(EstimatorObservation, env).last_estimate
        assert estimate is not None
        self.bus.send(self.robot.to_lerobot(self._inner.action_to_command(step.action)),
                      estimate.trust)


class ServoOut:
    """Observer: each frame's joint command to ``servo`` (a `ServoBridge`): the position
    command of the controller's action, or the simulated robot's angle under another
    control mode."""

    def __init__(self, servo: Any) -> None:
        self.servo = servo
        self._inner: Any = None

    def on_step(self, env: gym.Env, step: Step) -> None:
        if self._inner is None:  # the env under the wrappers, found once
            self._inner = imitate_env(env)
        inner = self._inner
        self.servo.send(inner.action_to_command(step.action) if inner.control == "position"
                        else step.obs["qpos"])


def mimic_frames(env: EstimatorObservation, controller: Any, log: MimicLog, rows: Any = None,
                 servo: Any = None, observers: Sequence[Observer] = (),
                 realtime: bool = False, robot: Any = None) -> Iterator[np.ndarray]:
    """Run ``controller`` on the estimator-wrapped ``env`` to the end of its clip (or of
    the stream) through `rollout.episode`, yielding each side-by-side frame (H, 2W, 3)
    uint8 RGB as it is made.

    Observers, in order: the joint command to ``servo`` (a `ServoBridge`) and ``log``
    (the estimate, robot angle and latency); then, once the frame is drawn, a row into the
    csv writer ``rows`` and ``observers`` (a progress display). A frame interrupted
    (Ctrl-C) anywhere from its logging to its drawing is taken back out of ``log``
    (`MimicLog.truncate`); a Ctrl-C from its row until the
    consumer asks for the next frame is raised then, so the log, the CSV and the frames
    yielded end at the same frame. A stream that ends early ends the run, not an error.
    ``realtime`` waits until frame i's time (i / fps after the first). ``robot``: a
    spatial robot's description (`robots.SO101Spec`) on ``ImitateVideo3D-v0``: its rows
    are `spatial_csv_header`'s and ``servo`` is its bus (an `SO101Bus`, `BusOut`).
    """
    watching: list[Observer] = ([] if servo is None else [ServoOut(servo)] if robot is None
                                else [BusOut(servo, robot)])
    drawn: list[Observer] = ([] if rows is None else [CsvLog(rows, log)] if robot is None
                             else [SpatialCsvLog(rows, log, robot)])
    drawn.extend(observers)
    for step in episode(env, controller, seed=0, observers=watching, realtime=realtime):
        logged = len(log.time)
        try:  # a Ctrl-C from logging the frame to its picture: the frame is not logged
            log.on_step(env, step)
            frame = cast(np.ndarray, env.render())  # render_mode="rgb_array"
        except BaseException:
            log.truncate(logged)
            raise
        with ctrl_c_held():  # the row, the progress and the video all take the frame
            for observer in drawn:
                observer.on_step(env, step)
            yield frame


class _Progress:
    """Observer: the progress bar, with latency, eta and a status twice a second."""

    def __init__(self, bar: Any, log: MimicLog, real_people: bool) -> None:
        self.bar, self.log, self.real_people = bar, log, real_people
        self.last_update = time.perf_counter()

    def on_step(self, env: gym.Env, step: Step) -> None:
        self.bar.update(1)
        now, log = time.perf_counter(), self.log
        if now - self.last_update > 0.5 and len(log.latency_ms) > 1:
            status = ("reading" if log.trust[-1] > 0
                      else "nobody in view: holding" if self.real_people else "no reading")
            self.bar.set_postfix(latency_ms=f"{np.mean(log.latency_ms[-30:]):.1f}",
                                 eta=f"{log.trust[-1]:.2f}", status=status)
            self.last_update = now


def write_behind(path: Path, frames: Iterator[np.ndarray], fps: float,
                 depth: int = 8, finish_within: float = 30.0) -> None:
    """`write_video` on a thread of its own, fed through a queue of ``depth`` frames, so
    that encoding a frame overlaps estimating the next (the encoder and the estimator
    then share the two cores). The file is finalised whatever ends the run (Ctrl-C
    included), with every frame ``frames`` yielded exactly once, even one whose hand-over
    Ctrl-C interrupted; an error of the writer's is raised here. Finishing (the queued
    frames encoded, the file's index written) ignores a second Ctrl-C and waits at most
    ``finish_within`` seconds: a writer still busy then raises `TimeoutError` (the file
    may not play)."""
    done = object()
    pending: queue.Queue = queue.Queue(maxsize=depth)
    failed: list[BaseException] = []
    finished = threading.Event()  # the writer has taken the end marker

    def feed() -> Iterator[np.ndarray]:
        written = 0  # frames are numbered, so one handed over twice is written once
        while (item := pending.get()) is not done:
            number, frame = item
            if number == written:
                written += 1
                yield frame
        finished.set()

    def write() -> None:
        try:
            write_video(path, feed(), fps)
        except BaseException as error:  # handed to the caller below
            failed.append(error)
            while not finished.is_set() and pending.get() is not done:  # let the producer
                pass                                                     # finish

    writer = threading.Thread(target=write, name="mimic.mp4 writer", daemon=True)
    writer.start()
    made = 0
    frame = None
    try:
        for frame in frames:
            made += 1
            pending.put((made - 1, frame))
            if failed:
                break
    finally:
        close = getattr(frames, "close", None)
        if close is not None:  # a generator left mid-way (the writer failed) ends here
            close()
        # Ctrl-C may land while a frame waits for room in the queue or just after it
        # went in: handing the last frame over again is safe either way. A second one
        # must not cut the finish short: the file's index is written last.
        with unstoppable():
            end = time.monotonic() + finish_within
            try:
                if made and not failed:
                    pending.put((made - 1, frame), timeout=finish_within)
                pending.put(done, timeout=max(end - time.monotonic(), 1e-3))
            except queue.Full:  # the writer is stuck: it takes no more
                pass
            writer.join(timeout=max(end - time.monotonic(), 0.0))
        if writer.is_alive():
            raise TimeoutError(f"{path}: the video writer did not finish within "
                               f"{finish_within:g} s; the file may not play")
    if failed:
        raise failed[0]


def steady_rate(log: MimicLog) -> float:
    """Frames/s from the first frame done to the last: the start-up (the first decode,
    the renderer's GL context) is left out, as it is paid once however long a run is."""
    if log.first_done is None or log.last_done is None or len(log.time) < 2:
        return 0.0
    return (len(log.time) - 1) / max(log.last_done - log.first_done, 1e-9)


def run_mimic(clip: Any, out: str | Path, estimator: str = "don", control: str = "position",
              estimator_params: dict[str, Any] | None = None, servo: Any = None,
              progress: bool = True, realtime: bool = False,
              preview_height: int | None = PREVIEW_HEIGHT,
              robot: str | None = None, mapping: str = "mirror") -> dict[str, Any]:
    """Mimic the arm in ``clip`` (a `Clip`, typically from `stream_video`) and write the
    outputs into ``out`` (see the module docstring). ``realtime`` paces a file to its own
    frame rate (a servo then moves at the person's speed; a camera paces itself). Returns
    the summary also written to ``mimic.json``: frames, wall time, frames/s, latency, mean
    eta, how the run ended. The clip's stream and ``servo`` are closed at the end.
    ``preview_height``: rows of ``mimic.mp4`` where the footage has more (None: the
    footage's); the estimator always reads the full frames. ``robot="so101"``: the arm
    is read in 3-D by a spatial estimator (``pose3d``) and copied by the SO-101 of
    ``ImitateVideo3D-v0`` under the person-to-robot ``mapping`` (`retarget.MAPPINGS`);
    ``servo`` is then its bus (`hardware.SO101Bus`) and mimic.csv has
    `spatial_csv_header`'s columns."""
    from tqdm.auto import tqdm

    from imimic_gym.controllers import EstimateTarget, PDController
    from imimic_gym.plots import plot_tracking

    entry = get_estimator(estimator)
    params = dict(estimator_params or {})
    needed = entry.frames_needed(params)
    source = str(clip.meta.get("path", "the clip"))
    live = clip.meta.get("source") == "camera"
    known_length = getattr(clip.frames, "length_known", True)
    cut_short = getattr(clip.frames, "cut_short", False)
    why = (f"{estimator.upper()} (window {needed - 1})" if needed > 1
           else f"{estimator.upper()}")
    if needed < 2:  # an estimator that reads a frame alone: the env's first step needs two
        needed, why = 2, "one step (from a frame to the next)"
    try:
        if not live and known_length:
            require_frames(len(clip), needed,
                           f"{source}, cut to its first frames," if cut_short else source, why)
        scene = (gym.make("ImitateVideo-v0", clip=clip, control=control,
                          render_mode="rgb_array", render_height=preview_height)
                 if robot is None else
                 gym.make("ImitateVideo3D-v0", clip=clip, robot=robot, mapping=mapping,
                          render_mode="rgb_array", render_height=preview_height))
        # A file's robot view draws while the estimator reads the frame (RenderAhead), and
        # the estimator reads the next frame while this one is worked on. A camera's next
        # frame is read once this one's command is out, and read by the estimator while
        # this frame's picture is drawn and written; nothing is drawn before the command.
        env = RegistryObservation(scene if live else RenderAhead(scene), estimator,
                                  keep_frame=False, estimate_ahead=True,
                                  ahead_when_drawn=live, **params)
    except BaseException:  # release the camera or file before the error goes up
        if hasattr(clip.frames, "close"):
            clip.frames.close()
        raise
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    controller = PDController(env, EstimateTarget(env))
    log = MimicLog(fps=float(clip.fps), clock=getattr(clip.frames, "clock", None) if live
                   else None)
    bar = tqdm(total=len(clip) if known_length else None, unit="frame", disable=not progress,
               desc=f"mimic {Path(source).name}")
    show = _Progress(bar, log, entry.real_people)

    ended = "end of footage"
    started = time.perf_counter()
    with (out / "mimic.csv").open("w", newline="", buffering=1) as table:
        rows = csv.writer(table)
        spec = None if robot is None else imitate_env(env).arm
        camera_fov = None
        if robot is not None:  # the camera the 3-D reading assumed (given or guessed)
            from imimic_gym.envs.imitate_video_3d import ImitateVideo3DEnv

            inner = imitate_env(env)
            assert isinstance(inner, ImitateVideo3DEnv)
            camera_fov = round(inner.intrinsics().fov_deg, 2)
        rows.writerow(csv_header(env.n) if spec is None
                      else spatial_csv_header(spec.joint_names))
        try:
            # What the first frame would pay for is paid now: the pose model's first
            # reading (on a blank frame) and, for a camera, the robot view's GL context.
            # Then a live stream's frames that queued up meanwhile are passed over, so
            # the robot starts on the picture of now, and so are those that queue up
            # later if the loop falls behind the source.
            env.warm_up()
            if live and hasattr(clip.frames, "keep_live"):
                imitate_env(env).prepare_render()
                clip.frames.keep_live()
            write_behind(out / "mimic.mp4",
                         mimic_frames(env, controller, log, rows, servo, [show], realtime,
                                      robot=spec),
                         clip.fps)
        except CTRL_C as error:
            if not is_ctrl_c(error):
                raise
            ended = "stopped by Ctrl-C"
        except RobotLinkLost as error:  # the robot is gone: end the run, keep the outputs
            ended = f"stopped: {error}"
        finally:
            wall = time.perf_counter() - started
            if ended == "end of footage":  # the bar ends at the frames the footage held
                bar.total = bar.n
                bar.refresh()
            bar.close()
            env.close()
            if hasattr(clip.frames, "close"):
                clip.frames.close()
            if servo is not None:
                with unstoppable():  # a second Ctrl-C must not cut the release short
                    servo.close()
    frames = len(log.time)
    reader = getattr(clip.frames, "reader", None)
    skipped = int(getattr(reader, "skipped_frames", 0))
    stopped = ended != "end of footage"  # by Ctrl-C: too few frames is then no error
    if not stopped and frames:
        if live and frames < len(clip):
            ended = "camera stopped"
        elif known_length and frames + skipped < len(clip):
            if reader is None or reader.ended_early():  # else an intact file's end
                ended = (f"footage ended early: {frames} of the {len(clip)} frames "
                         f"{'asked for' if cut_short else 'its container reports'}"
                         f"{f' ({skipped} more failed to decode)' if skipped else ''} "
                         f"(a truncated or damaged file?)")
        elif cut_short:
            ended = f"stopped at the {len(clip)} frames asked for"
    if frames:
        plot_tracking(log.trajectory(), out / "angles.png", target_label=estimator.upper(),
                      title=f"{Path(source).name}: {estimator.upper()} estimate (solid) vs "
                            f"robot (dashed)")
    latency = np.asarray(log.latency_ms) if frames else np.zeros(1)
    summary = {
        "source": source,
        "estimator": estimator,
        "control": control,
        "frames": frames,
        "video_fps": float(clip.fps),
        "wall_s": wall,
        "frames_per_s": steady_rate(log),
        "latency_ms_median": float(np.median(latency)),
        "latency_ms_p95": float(np.percentile(latency, 95)),
        "mean_trust": float(np.mean(log.trust)) if frames else 0.0,
        "frames_without_reading": int(np.sum(np.asarray(log.trust) == 0.0)),
        "predicted_fraction": float(np.mean(log.predicted)) if frames else 0.0,
        "skipped_frames": skipped,
        "ended": ended,
    }
    if servo is not None and robot is None:
        summary["servo_commands_sent"], summary["servo_errors"] = servo.sent, servo.errors
    if robot is not None:
        summary["robot"], summary["mapping"] = robot, mapping
        summary["camera_fov_deg"] = camera_fov
    if live:
        behind = log.behind_stream_ms()
        summary["frames_passed_over"] = int(getattr(clip.frames, "passed_over", 0))
        summary["behind_stream_ms_median"] = float(np.median(behind)) if len(behind) else None
        summary["behind_stream_ms_max"] = float(np.max(behind)) if len(behind) else None
    write_json(out / "mimic.json", summary)
    require_frames(frames, 0 if stopped or live else needed, source, why)
    return summary
