"""The pretrained human-pose model, behind one small class: the only module that imports
MediaPipe.

`PoseModel` runs MediaPipe Pose (BlazePose GHUM, the "full" landmark model and the person
detector, both inside the ``mediapipe==0.10.14`` wheel: nothing is downloaded) on the
CPU and returns one person's body keypoints in input pixels with a confidence each, the
model's relative depth of each and its 3-D "world" landmarks (`BodyKeypoints`), or None
where it sees nobody. Why this model and this version, and
how it is installed beside our numpy and OpenCV: `docs/decisions/pose-model.md`.

A caller that knows its next frames (a video file) may hand them over ahead
(`PoseModel.submit`): they are read in order on a thread of the model's own while the
caller works on the frame before, and the call for each returns what it would have
returned alone.
"""

from __future__ import annotations

import contextlib
import math
import os
import queue
import sys
import threading
import warnings
from collections import deque
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Any

import cv2
import numpy as np

__all__ = ["KEYPOINTS", "MEDIAPIPE_VERSION", "NATIVE_LOGS", "BodyKeypoints", "PoseModel",
           "PoseModelMissingError", "native_logs_quiet"]

MEDIAPIPE_VERSION = "0.10.14"
NATIVE_LOGS = "IMIMIC_NATIVE_LOGS"  # set (to anything but ""): MediaPipe's log lines show
# Body keypoints we read, the person's own left and right (a person facing the camera
# has their left side on the image's right).
KEYPOINTS = ("left_shoulder", "right_shoulder", "left_elbow", "right_elbow", "left_wrist",
             "right_wrist", "left_hip", "right_hip", "left_hand", "right_hand")
# Their BlazePose landmark indices (the hand is the index finger's knuckle).
_BLAZEPOSE = (11, 12, 13, 14, 15, 16, 23, 24, 19, 20)
_LEGACY_STEP_US = 33333  # the legacy solution's own step between frames (as at 30 fps)


class PoseModelMissingError(ImportError):
    """MediaPipe is not installed (it is an optional part: the ``pose`` extra)."""


@dataclass(frozen=True)
class BodyKeypoints:
    """One person's keypoints in one frame.

    Attributes:
        points: (K, 2) float64 input pixels (x, y), K = len(KEYPOINTS), in that order.
        confidence: (K,) float64 in [0, 1]: the model's visibility of each keypoint.
        depth: (K,) float64, the model's relative depth of each keypoint (MediaPipe's
            ``landmark.z``): 0 at the hips' midpoint, smaller = nearer the camera, in
            image widths (roughly the scale of the normalised x, so ``depth * W`` is
            pixels for a W-pixel-wide frame); None where not read (hand-built keypoints).
        world: (K, 3) float64 metres, the model's own 3-D estimate (MediaPipe's
            ``pose_world_landmarks``): origin at the hips' midpoint, x towards the image's
            right, y down, z away from the camera (axes as the image's; rotation about
            the hips is the model's guess); None where not read.
    """

    points: np.ndarray
    confidence: np.ndarray
    depth: np.ndarray | None = None
    world: np.ndarray | None = None

    def __post_init__(self) -> None:
        k = len(KEYPOINTS)
        if self.points.shape != (k, 2) or self.confidence.shape != (k,):
            raise ValueError(f"BodyKeypoints needs points ({k}, 2) and confidence ({k},), "
                             f"got {self.points.shape} and {self.confidence.shape}")
        for name, shape in (("depth", (k,)), ("world", (k, 3))):
            value = getattr(self, name)
            if value is not None and np.shape(value) != shape:
                raise ValueError(f"BodyKeypoints.{name} must have shape {shape}, got "
                                 f"{np.shape(value)}")
        arrays = [a for a in (self.points, self.confidence, self.depth, self.world)
                  if a is not None]
        if not all(np.isfinite(a).all() for a in arrays):
            raise ValueError("BodyKeypoints must be finite")

    def get(self, name: str) -> tuple[np.ndarray, float]:
        """The keypoint ``name``'s (2,) pixel position and its confidence."""
        i = KEYPOINTS.index(name)
        return self.points[i], float(self.confidence[i])

    def arm(self, side: str) -> tuple[np.ndarray, np.ndarray]:
        """Shoulder, elbow, wrist of ``side`` ("left" or "right"): (3, 2) px, (3,)."""
        rows = [KEYPOINTS.index(f"{side}_{joint}") for joint in ("shoulder", "elbow", "wrist")]
        return self.points[rows], self.confidence[rows]

    def facing_camera(self) -> bool:
        """True when the person's left shoulder lies right of their right shoulder in the
        image (they face the camera); False when their back is to it."""
        return bool(self.get("left_shoulder")[0][0] > self.get("right_shoulder")[0][0])


@contextlib.contextmanager
def native_logs_quiet() -> Iterator[None]:
    """Standard error (file descriptor 2, which MediaPipe's native code writes its log
    lines to, from its own threads too) goes to the null device while this runs, unless
    the environment sets IMIMIC_NATIVE_LOGS (`imimic --verbose`). A graph writes its
    lines as it starts and reads its first frame."""
    if os.environ.get(NATIVE_LOGS):
        yield
        return
    sys.stderr.flush()
    kept = os.dup(2)
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, 2)
        os.close(devnull)
        yield
    finally:
        os.dup2(kept, 2)
        os.close(kept)


def _check_frame(frame: Any) -> None:
    if not (isinstance(frame, np.ndarray) and frame.dtype == np.uint8 and frame.ndim == 3
            and frame.shape[2] == 3 and frame.shape[0] > 0 and frame.shape[1] > 0):
        got = (f"{frame.shape} {frame.dtype}" if isinstance(frame, np.ndarray)
               else type(frame).__name__)
        raise ValueError(f"PoseModel takes (H, W, 3) uint8 RGB frames, got {got}")


def _solution() -> Any:
    """MediaPipe's legacy Pose solution module (imported here only)."""
    try:
        from mediapipe.python.solutions import pose
    except ImportError as error:
        running = f"{sys.version_info.major}.{sys.version_info.minor}"
        raise PoseModelMissingError(
            f"the pose estimator needs MediaPipe {MEDIAPIPE_VERSION}, which has wheels for "
            f"Python 3.9-3.12 only (this is {running}): pip install '.[pose]' in a clone of "
            f"imimic_gym, then pip install --no-deps mediapipe=={MEDIAPIPE_VERSION} (make "
            f"setup does both); "
            f"{error}") from error
    return pose


class _Reading:
    """One frame handed to `PoseModel.submit` (``frame``, and ``read()`` of its reading):
    read on the model's thread, its result (or error) kept for the call that asks for it."""

    def __init__(self, frame: np.ndarray, time_s: float | None,
                 read: Callable[[], BodyKeypoints | None]) -> None:
        self.frame, self.time_s = frame, time_s
        self._read: Callable[[], BodyKeypoints | None] | None = read
        self.done = threading.Event()
        self.result: BodyKeypoints | None = None
        self.error: BaseException | None = None

    def run(self) -> None:
        read, self._read = self._read, None  # holds the model only while it waits or runs
        try:
            if read is not None:
                self.result = read()
        except BaseException as error:  # handed to the caller that asks for this frame
            self.error = error
        finally:
            self.done.set()

    def cancel(self) -> None:
        """Not read if not started yet."""
        self._read = None


def _read_ahead(readings: queue.Queue[_Reading | None]) -> None:
    """A `PoseModel`'s thread: the frames submitted, read in order, until None comes."""
    while (reading := readings.get()) is not None:
        reading.run()


class PoseModel:
    """MediaPipe Pose on the CPU: (H, W, 3) uint8 RGB frame in, `BodyKeypoints` or None.

    Args:
        video: True for the frames of one video in order: the landmark model follows the
            person from the previous frame's region, and the detector runs only when it
            loses them (the person already tracked stays chosen when others walk in).
            False treats every frame as a separate photo (the detector picks the most
            salient person).
        min_confidence: the detector's and tracker's thresholds, in [0, 1].
        max_side: frames with a longer side are area-averaged down to it first; the
            model reads a 256x256 crop, so a 1080p frame only costs more to convert.
        join_timeout_s: how long `close` waits for a frame being read ahead (`submit`).

    Frames handed over ahead (`submit`) are read on the model's thread (``thread``, a
    daemon, started by the first of them); `close` and `reset` drop those not read yet
    and stop the thread. The graph starts at a video's first frame, or before it with
    `warm_up`; close the model when done with it (a graph holds about 100 MB).
    """

    def __init__(self, video: bool = True, min_confidence: float = 0.5,
                 max_side: int = 640, join_timeout_s: float = 10.0) -> None:
        if not 0.0 <= min_confidence <= 1.0:
            raise ValueError(f"min_confidence must be in [0, 1], got {min_confidence!r}")
        if max_side < 64:
            raise ValueError(f"max_side must be at least 64 px, got {max_side!r}")
        _solution()  # fail here, with how to install it, rather than at the first frame
        self.video, self.min_confidence, self.max_side = video, min_confidence, max_side
        self.join_timeout_s = join_timeout_s
        self._graph: Any = None
        self._warm = False  # the graph has read `warm_up`'s blank frame and nothing since
        self._origin_us = 0  # the stamp frame times count from (past the blank frame's)
        self._submitted: deque[_Reading] = deque()  # in order, until called for
        self._readings: queue.Queue[_Reading | None] = queue.Queue()
        self.thread: threading.Thread | None = None
        self.reset()

    def reset(self) -> None:
        """Forget the person tracked so far: the next frame starts a new video (the
        model's graph starts on that frame, unless `warm_up` started it and it has read
        nothing since)."""
        if not (self._warm and self.thread is None and not self._submitted):
            self.close()

    def warm_up(self) -> None:
        """Start the graph now and read one blank frame with it, so that the video's
        first frame reads at full speed: a new graph's first reading costs several
        frames' time (the models' tensors and kernels are set up then), which a live
        stream would otherwise pay after it was caught up with. The readings that follow
        are those a fresh graph gives (the blank frame holds nobody, so no filter keeps
        a state from it; their frame times count from past its stamp). Nothing if the
        graph has started already."""
        if self._graph is not None:
            return
        with native_logs_quiet():
            self._start()
            graph: Any = self._graph
            graph.process(np.zeros((256, 256, 3), dtype=np.uint8))
        self._origin_us = graph._simulated_timestamp
        self._warm = True

    def _start(self) -> None:
        self._graph = _solution().Pose(
            static_image_mode=not self.video, model_complexity=1, smooth_landmarks=True,
            enable_segmentation=False, min_detection_confidence=self.min_confidence,
            min_tracking_confidence=self.min_confidence)

    # A copy or an unpickled model is a new model with the same settings: MediaPipe's graph
    # is native code, and a copy starts a new video anyway.
    def __getstate__(self) -> dict[str, Any]:
        return {"video": self.video, "min_confidence": self.min_confidence,
                "max_side": self.max_side, "join_timeout_s": self.join_timeout_s}

    def __setstate__(self, state: dict[str, Any]) -> None:
        PoseModel.__init__(self, **state)

    def __deepcopy__(self, memo: dict[int, Any]) -> PoseModel:
        return PoseModel(**self.__getstate__())

    def __del__(self) -> None:
        if getattr(self, "thread", None) is not None:
            self._readings.put(None)

    def close(self) -> None:
        """Drop the frames submitted and not read yet, stop the model's thread (waiting at
        most ``join_timeout_s`` for the frame it reads) and close the graph."""
        submitted, self._submitted = self._submitted, deque()
        for reading in submitted:
            reading.cancel()
        thread, self.thread = self.thread, None
        if thread is not None:
            self._readings.put(None)
            thread.join(timeout=self.join_timeout_s)
            self._readings = queue.Queue()
            if thread.is_alive():  # still in the graph: left to it, not closed under it
                self._graph = None
        if self._graph is not None:
            self._graph.close()
            self._graph = None
        self._warm, self._origin_us = False, 0

    @property
    def pending(self) -> int:
        """Frames submitted and not yet called for."""
        return len(self._submitted)

    def submit(self, frame: np.ndarray, time_s: float | None = None) -> None:
        """Hand over the frame that comes after those called for or submitted so far, to
        be read on the model's thread while the caller does other work; the call for it
        (``model(frame, time_s)``, the same array and time) then returns its result, or
        raises its error. ``frame`` must not change until then. The first frame of a
        video (the graph starting) is read here, on the caller's thread; so is each
        frame's shrinking to ``max_side``, which leaves the model's thread only the model."""
        _check_frame(frame)
        small = self._shrink(frame)
        reading = _Reading(frame, time_s,
                           lambda: self._read(small, frame.shape[:2], time_s))
        self._submitted.append(reading)
        if self._graph is None:
            reading.run()
            return
        if self.thread is None:
            self.thread = threading.Thread(target=_read_ahead, args=(self._readings,),
                                           name="pose model", daemon=True)
            self.thread.start()
        self._readings.put(reading)

    def __call__(self, frame: np.ndarray, time_s: float | None = None
                 ) -> BodyKeypoints | None:
        """One frame's person. ``time_s``: the frame's time in the video (s), increasing
        from call to call; None takes the previous call's plus 1/30 s. In video mode the
        model's filters (the landmarks' smoothing, the next frame's region) weigh motion by
        the time between calls, so a video at another rate, or one read every few frames,
        needs its real times. With frames submitted (`submit`), this must be the first of
        them (the same array and time): RuntimeError otherwise."""
        _check_frame(frame)
        if not self._submitted:
            return self._read(self._shrink(frame), frame.shape[:2], time_s)
        reading = self._submitted[0]
        if reading.frame is not frame or reading.time_s != time_s:
            raise RuntimeError(f"PoseModel: asked for a frame at {time_s!r} s that is not the "
                               f"next one submitted (at {reading.time_s!r} s): frames "
                               f"submitted ahead are called for in order, the same arrays")
        while not reading.done.wait(timeout=0.1):
            if self.thread is None or not self.thread.is_alive():
                raise RuntimeError("PoseModel: the thread reading frames ahead has stopped "
                                   "before reading this one")
        self._submitted.popleft()
        if reading.error is not None:
            raise reading.error
        return reading.result

    def _shrink(self, frame: np.ndarray) -> np.ndarray:
        """A checked frame area-averaged down to ``max_side`` on its longer side (as it
        is if no longer), in contiguous memory: what the graph reads."""
        h, w = frame.shape[:2]
        scale = max(h, w) / self.max_side
        if scale > 1:
            frame = cv2.resize(frame, (max(1, round(w / scale)), max(1, round(h / scale))),
                               interpolation=cv2.INTER_AREA)
        return np.ascontiguousarray(frame)

    def _read(self, small: np.ndarray, size: tuple[int, ...], time_s: float | None
              ) -> BodyKeypoints | None:
        """`__call__`'s reading of a frame of ``size`` (rows, columns) shrunk to ``small``
        (`_shrink`), on whichever thread reads it."""
        starting = self._graph is None
        if starting:
            with native_logs_quiet():
                self._start()
        if time_s is not None:
            # MediaPipe's timestamps are microseconds; the legacy solution stamps each frame
            # one step after the last, so the first frame (time 0) gets one step past the
            # origin (0, or `warm_up`'s blank frame). Set the last stamp so that this frame
            # gets its own time.
            last, origin = self._graph._simulated_timestamp, self._origin_us
            if not (math.isfinite(time_s) and time_s >= 0
                    and _LEGACY_STEP_US + origin + round(time_s * 1e6) > last):
                after = ("" if last == origin
                         else f" after {(last - origin - _LEGACY_STEP_US) / 1e6:g} s")
                raise ValueError(f"PoseModel: frame times must be at least 0 s and increase "
                                 f"from call to call, got {time_s!r} s{after}")
            self._graph._simulated_timestamp = origin + round(time_s * 1e6)
        self._warm = False
        h, w = size[:2]
        with warnings.catch_warnings():
            # protobuf 4.25 warns of an API MediaPipe 0.10.14 calls on every frame.
            warnings.filterwarnings("ignore", message="SymbolDatabase.GetPrototype",
                                    category=UserWarning)
            with native_logs_quiet() if starting else contextlib.nullcontext():
                result = self._graph.process(small)
        if result.pose_landmarks is None:
            return None
        marks = result.pose_landmarks.landmark
        points = np.array([(marks[i].x * w, marks[i].y * h) for i in _BLAZEPOSE])
        confidence = np.array([marks[i].visibility for i in _BLAZEPOSE])
        depth = np.array([marks[i].z for i in _BLAZEPOSE])
        world = None
        if result.pose_world_landmarks is not None:
            world_marks = result.pose_world_landmarks.landmark
            world = np.array([(world_marks[i].x, world_marks[i].y, world_marks[i].z)
                              for i in _BLAZEPOSE])
            if not np.isfinite(world).all():
                world = None
        if not all(np.isfinite(a).all() for a in (points, confidence, depth)):
            return None
        return BodyKeypoints(points=points, confidence=np.clip(confidence, 0.0, 1.0),
                             depth=depth, world=world)
