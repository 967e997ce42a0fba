"""Video files and cameras read through OpenCV as (H, W, 3) uint8 RGB frames (writing:
`clips.video_writer`).

- `VideoReader` streams a recorded file (anything OpenCV's FFmpeg backend reads: mp4,
  avi, mkv, mjpeg...), an image sequence (a printf pattern such as ``frame_%04d.png``,
  read by OpenCV's image-sequence backend, each image at its own size), a camera index
  (``0``) or a stream URL (``rtsp://...``). One frame is held at a time; the capture is
  released in ``finally`` when the stream ends, fails or is abandoned.
- `clips.video_load.load_video` reads a whole file into a `Clip` (random access: what
  an RL env resets into); `stream_video` wraps a reader in a `Clip` whose frames are a
  `FrameStream`, read on demand and kept in a bounded buffer, so a live camera never
  needs the whole stream in memory. A file's stream is decoded on a thread of its own a
  frame or two ahead of the caller (`ReadAhead`), so that decoding overlaps the work on the
  frame before; a camera's or URL's is read when asked for, so that each frame is the
  newest one the source has.

Problems are named: a source that cannot be opened raises `VideoOpenError` (an OSError);
one with no decodable frame or whose resolution changes mid-stream raises
`VideoFormatError` (a ValueError); both messages name the source. A frame that fails to
decode in the middle of a file is skipped and counted (``skipped_frames``), not fatal:
after up to ``max_consecutive_failures`` failed reads the stream is taken to have ended.

Footage without known geometry gets documented defaults, overridable by the caller:
the reference link points down the image (`DEFAULT_REFERENCE_DIRECTION`: an upper arm
hanging by the body, or a servo horn's zero mark filmed pointing down) and every joint
spans the paper's 120-degree servo range centred on it (`DEFAULT_JOINT_RANGE`).
"""

from __future__ import annotations

import contextlib
import math
import os
import queue
import subprocess
import threading
import time
from collections import deque
from collections.abc import Generator, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from imimic_gym.clips.types import Clip

__all__ = [
    "DEFAULT_JOINT_RANGE", "DEFAULT_REFERENCE_DIRECTION", "FrameStream", "ReadAhead",
    "StreamClock", "StreamEndedError", "VideoFormatError", "VideoOpenError", "VideoReader",
    "require_frames", "stream_video", "video_meta",
]

DEFAULT_REFERENCE_DIRECTION = -math.pi / 2  # image down (CCW from image right)
DEFAULT_JOINT_RANGE = (-math.pi / 3, math.pi / 3)  # the paper's 120-degree servo, centred
LIVE_FPS = 30.0  # a camera that does not report its rate is taken to run at this
UNBOUNDED = 2**31 - 1  # the nominal length of a stream whose length is unknown (frames)
_COPIES_KEPT = 4  # a FrameStream's copies for `fresh` of the last frames read, at most
MAX_SKIP_S = 5.0  # `VideoReader.skip_queued` passes over at most this much of a stream (s)
REFERENCE_S = 10.0  # `VideoReader.behind_s` compares with the reads of this last while (s)
MAX_BEHIND_S = 0.3  # a live frame read this much later than the promptest: the queue skipped
START_DRAIN_S = 1.0  # `FrameStream.keep_live` reads on past the clock this much at most (s)


class VideoOpenError(OSError):
    """A video source could not be opened; the message names it and the reason."""


class VideoFormatError(ValueError):
    """A video opened but its content is unusable (no frames, a resolution change, too
    short); the message names the source and the problem."""


class StreamEndedError(IndexError):
    """A `FrameStream` ran out (the file ended early or the camera disappeared)."""


def _is_live(source: str | int | Path) -> bool:
    if isinstance(source, int):
        return True
    text = str(source)
    return text.isdigit() or "://" in text


def _describe(source: str | int | Path) -> str:
    if isinstance(source, int) or str(source).isdigit():
        return f"camera {int(str(source))}"
    return str(source)


@contextlib.contextmanager
def _ffmpeg_quiet() -> Iterator[None]:
    """OpenCV's own warnings off while a capture opens, and FFmpeg's log lines (a damaged
    file's "Invalid NAL unit size", a non-video's "moov atom not found") off for the
    process, unless the environment sets IMIMIC_NATIVE_LOGS (`imimic --verbose`): what
    goes wrong is said in one line by the caller. A user's own OPENCV_FFMPEG_LOGLEVEL
    wins; OpenCV reads it when its FFmpeg backend first opens a file."""
    if os.environ.get("IMIMIC_NATIVE_LOGS"):
        yield
        return
    os.environ.setdefault("OPENCV_FFMPEG_LOGLEVEL", "-8")  # AV_LOG_QUIET
    level = cv2.utils.logging.getLogLevel()
    cv2.utils.logging.setLogLevel(cv2.utils.logging.LOG_LEVEL_ERROR)
    try:
        yield
    finally:
        cv2.utils.logging.setLogLevel(level)


class VideoReader:
    """Frames of a video file, image sequence, camera or stream URL, one at a time.

    Use as a context manager or iterate it directly (the capture is released when the
    iteration ends, raises or is closed)::

        with VideoReader("clip.mp4") as video:
            for frame in video:      # (H, W, 3) uint8 RGB
                ...

    Args:
        source: a path, a printf image pattern, a camera index (int or "0") or a URL.
        fps: the frame rate to use when the source does not report one (image
            sequences; cameras default to `LIVE_FPS`). A file's own rate wins.
        max_consecutive_failures: failed reads in a row after which the stream has
            ended; fewer, followed by a good frame, are skipped corrupt frames.
        decode_threads: FFmpeg's decoding threads for a video file (None: OpenCV's
            default, one a core). The frames are the same with any number; one costs
            the least CPU in all, where nobody waits on each frame's decoding (a
            `ReadAhead`).

    Attributes (after opening): ``fps`` (float, frames/s), ``width``, ``height``
    (pixels, of the first frame once read, else as the container reports),
    ``frame_count`` (the container's count, None when unknown or live),
    ``frames_read``, ``skipped_frames``, ``live``; for a live source, ``last_clock``
    (`StreamClock` of the last frame read, or None) and ``dropped_frames`` (passed over
    by `skip_queued`).
    """

    def __init__(self, source: str | int | Path, fps: float | None = None,
                 max_consecutive_failures: int = 8, decode_threads: int | None = None) -> None:
        if fps is not None and not (math.isfinite(fps) and fps > 0):
            raise ValueError(f"fps must be a positive number of frames/s, got {fps!r}")
        if decode_threads is not None and decode_threads < 1:
            raise ValueError(f"decode_threads must be at least 1, got {decode_threads!r}")
        self.decode_threads = decode_threads
        self.source, self.name, self.live = source, _describe(source), _is_live(source)
        self.requested_fps = fps
        self.max_consecutive_failures = max_consecutive_failures
        self.capture: cv2.VideoCapture | None = None
        self.frames_read = self.skipped_frames = self.dropped_frames = 0
        self.shape: tuple[int, ...] | None = None
        self.last_clock: StreamClock | None = None
        self._offsets: deque[tuple[float, float]] = deque()  # (read at, less stream time)

    def open(self) -> VideoReader:
        if self.capture is not None:
            return self
        if not self.live:
            path = Path(str(self.source))
            pattern = "%" in path.name
            if not pattern and not path.exists():
                raise VideoOpenError(f"cannot open video {self.name}: no such file")
            if not pattern and path.is_dir():
                raise VideoOpenError(f"cannot open video {self.name}: it is a directory")
            if not pattern and path.stat().st_size == 0:
                raise VideoOpenError(f"cannot open video {self.name}: the file is empty")
            backend = cv2.CAP_IMAGES if pattern else cv2.CAP_FFMPEG
            threads = ([] if pattern or self.decode_threads is None
                       else [cv2.CAP_PROP_N_THREADS, self.decode_threads])
            with _ffmpeg_quiet():
                capture = cv2.VideoCapture(str(path), backend, threads)
        else:
            index = int(str(self.source)) if str(self.source).isdigit() else str(self.source)
            with _ffmpeg_quiet():
                capture = cv2.VideoCapture(index)
        if not capture.isOpened():
            capture.release()
            reason = ("no camera answers there" if self.live
                      else "OpenCV cannot decode it (not a video, or an unsupported codec)")
            raise VideoOpenError(f"cannot open video {self.name}: {reason}")
        if self.live:
            capture.set(cv2.CAP_PROP_BUFFERSIZE, 1)  # the newest frame, not a backlog
        reported = capture.get(cv2.CAP_PROP_FPS)
        if math.isfinite(reported) and reported > 0 and not self.live:
            self.fps = float(reported)
        elif self.requested_fps is not None:
            self.fps = float(self.requested_fps)
        elif self.live:
            self.fps = float(reported) if math.isfinite(reported) and reported > 0 else LIVE_FPS
        else:
            capture.release()
            raise VideoFormatError(
                f"{self.name} does not report its frame rate: give it one (--fps on the "
                f"command line; fps= to load_video or stream_video, whose Clip the env "
                f"takes as clip=)")
        count = capture.get(cv2.CAP_PROP_FRAME_COUNT)
        self.frame_count = int(count) if not self.live and 0 < count < 1e9 else None
        self.width = int(capture.get(cv2.CAP_PROP_FRAME_WIDTH))
        self.height = int(capture.get(cv2.CAP_PROP_FRAME_HEIGHT))
        self.capture = capture
        return self

    def close(self) -> None:
        if self.capture is not None:
            self.capture.release()
            self.capture = None

    def __enter__(self) -> VideoReader:
        return self.open()

    def __exit__(self, *exc: object) -> None:
        self.close()

    def _next_bgr(self) -> np.ndarray | None:
        """The next decodable frame, skipping (and counting) corrupt ones; None at the end."""
        assert self.capture is not None
        failures = 0
        while failures <= self.max_consecutive_failures:
            ok, frame = self.capture.read()
            if ok and frame is not None and frame.size:
                self.skipped_frames += failures
                return frame
            failures += 1
            if (self.frame_count is not None
                    and self.frames_read + self.skipped_frames + failures >= self.frame_count):
                return None  # past the last frame the container reports: no retries
            if self.live:
                time.sleep(0.05)  # a camera that hiccups gets a moment before it is given up
        return None

    def ended_early(self) -> bool:
        """After the stream has ended: whether it held fewer frames than the container
        reports because decoding failed (a truncated or damaged file). A file that
        ffmpeg (imageio-ffmpeg's) decodes to the end without an error is intact: its
        container counts frames that an edit list drops (OpenCV and ffmpeg decode fewer).
        False for a source whose length is unknown (a camera)."""
        if self.frame_count is None or self.frames_read + self.skipped_frames >= self.frame_count:
            return False
        if self.skipped_frames or "%" in Path(str(self.source)).name:
            return True
        return not _decodes_cleanly(Path(str(self.source)))

    def _clock(self) -> None:
        """A live source: note when its last frame was read and the stream's own time
        for it (None where the source keeps no clock: times that do not increase)."""
        assert self.capture is not None
        stream_s = self.capture.get(cv2.CAP_PROP_POS_MSEC) / 1000.0
        previous = self.last_clock
        ticking = math.isfinite(stream_s) and (
            previous.stream_s < stream_s if previous is not None else stream_s >= 0.0)
        self.last_clock = StreamClock(time.perf_counter(), stream_s) if ticking else None
        if self.last_clock is None:
            self._offsets.clear()  # a clock that restarts or stops: nothing to compare
            return
        read_at = self.last_clock.read_at
        self._offsets.append((read_at, read_at - stream_s))
        while self._offsets[0][0] < read_at - REFERENCE_S:
            self._offsets.popleft()

    def _rgb(self, bgr: np.ndarray) -> np.ndarray:
        """A decoded frame as RGB, checked against the stream's first frame's size."""
        if bgr.ndim == 2:
            bgr = cv2.cvtColor(bgr, cv2.COLOR_GRAY2BGR)
        if self.shape is None:
            self.shape = bgr.shape
            self.height, self.width = bgr.shape[:2]
        elif bgr.shape != self.shape:
            h, w = bgr.shape[:2]
            raise VideoFormatError(
                f"{self.name}: frame {self.frames_read + self.skipped_frames} is "
                f"{w}x{h} but the video started at {self.width}x{self.height}; "
                "a clip must keep one resolution"
            )
        self.frames_read += 1
        return cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB)

    def __iter__(self) -> Generator[np.ndarray, None, None]:
        self.open()
        try:
            while (bgr := self._next_bgr()) is not None:
                if self.live:
                    self._clock()
                yield self._rgb(bgr)
            if self.frames_read == 0:
                skipped = (f" ({self.skipped_frames} failed to decode)"
                           if self.skipped_frames else "")
                raise VideoFormatError(f"{self.name} has no frames that can be decoded{skipped}")
        finally:
            self.close()

    def behind_s(self) -> float:
        """A live source's last frame: how much later it was read than the promptest
        read of the last `REFERENCE_S` seconds would have it (each read's time less its
        stream time), in s; 0 without a clock."""
        if self.last_clock is None or not self._offsets:
            return 0.0
        last = self.last_clock
        return last.read_at - last.stream_s - min(offset for _, offset in self._offsets)

    def skip_queued(self, reference: float | None = None, drain_s: float = 0.0
                    ) -> np.ndarray | None:
        """A live source's frames that queued up while nobody read it, passed over; the
        newest frame read, or None if none was (no clock, or the source ended).

        ``reference``: a read's time less its stream time for a frame read as soon as
        it came (None: the promptest of the last `REFERENCE_S` seconds). The source is
        taken to send in real time, so while the last frame read is now over a frame's
        time later than that, a newer one has been sent: the next one is decoded and
        the one before dropped (``dropped_frames`` counts them), until one is not
        behind, or one had to be waited for over half a frame's time (it came fresh: the
        stream runs later than the reference, which it becomes). A stream sent ahead of
        real time loses nothing by the clock. Frames that were already waiting when the
        reference frame was read (OpenCV's probing of a stream, a sender that starts
        ahead) look on time to it: ``drain_s`` > 0 reads on past the clock's last frame
        while each frame comes at once, until one is waited for or ``drain_s`` of the
        stream has gone by (a source whose frames are all there at once, a file://
        URL, loses that much). At most `MAX_SKIP_S` of the stream's frames are passed
        over in all."""
        if (not self.live or self.capture is None or self.last_clock is None
                or (reference is None and not self._offsets)):
            return None
        if reference is None:
            reference = min(offset for _, offset in self._offsets)
        period = 1.0 / self.fps
        grabbed = 0
        drain_until: float | None = None  # stream time
        while self.last_clock is not None and grabbed < MAX_SKIP_S * self.fps:
            if time.perf_counter() - self.last_clock.stream_s - reference <= period:
                # Not behind by the clock: read on only while the frames were waiting.
                if drain_until is None:
                    drain_until = self.last_clock.stream_s + drain_s
                if self.last_clock.stream_s >= drain_until:
                    break
            started = time.perf_counter()
            if not self.capture.grab():
                break
            grabbed += 1
            self._clock()
            if self.last_clock is not None and self.last_clock.read_at - started > period / 2:
                # Waited for: this frame is fresh and the stream runs later than the
                # reference said (a network stall, a clock that drifts): it is the
                # reference from now on.
                self._offsets = deque([self._offsets[-1]])
                break
        if grabbed == 0:
            return None
        self.dropped_frames += grabbed  # the frame read before and all but the newest
        ok, bgr = self.capture.retrieve()
        return self._rgb(bgr) if ok and bgr is not None and bgr.size else None


@dataclass(frozen=True)
class StreamClock:
    """When a live source's frame was read (``read_at``, `time.perf_counter` seconds)
    and the stream's own time for it (``stream_s``, seconds, OpenCV's
    ``CAP_PROP_POS_MSEC``: the network stream's timestamp, a camera driver's buffer
    time)."""

    read_at: float
    stream_s: float


class _Failed:
    """The error that ended a `ReadAhead`'s decoding, handed over in its place."""

    def __init__(self, error: BaseException) -> None:
        self.error = error


_END = object()  # a `ReadAhead`'s decoding reached the end of the stream


def _hand_over(pending: queue.Queue[Any], stop: threading.Event, item: Any) -> bool:
    """Put ``item`` in ``pending`` as soon as there is room; False if ``stop`` is set first."""
    while not stop.is_set():
        try:
            pending.put(item, timeout=0.05)
            return True
        except queue.Full:
            continue
    return False


def _decode_ahead(reader: VideoReader, pending: queue.Queue[Any], stop: threading.Event,
                  limit: int | None, copies: bool) -> None:
    """A `ReadAhead`'s thread: ``reader``'s frames (each with a copy, with ``copies``) into
    ``pending``, then the end or the error; the capture released here, on the thread
    that reads it."""
    frames = iter(reader)
    outcome: Any = _END
    try:
        for count, frame in enumerate(frames, start=1):
            if not _hand_over(pending, stop, (frame, frame.copy() if copies else None)):
                return
            if limit is not None and count >= limit:
                break
    except BaseException as error:  # handed to the caller, in order
        outcome = _Failed(error)
    finally:
        frames.close()
        reader.close()
    _hand_over(pending, stop, outcome)


class ReadAhead:
    """The frames of a `VideoReader`, as ``iter(reader)`` gives them ((H, W, 3) uint8 RGB,
    in order, the same errors after the same frames), decoded on a thread of its own at
    most ``depth`` frames ahead of the caller.

    The thread owns the capture from the start: it opens the reader's iteration, and
    releases the capture itself when the stream ends, fails, reaches ``limit`` frames or
    is closed; nothing else may touch the reader's capture meanwhile. `close` stops it
    and waits up to ``join_timeout_s`` for it (it stops within one frame's decoding);
    an error of the decoding (`VideoFormatError`, say) is raised by the ``next`` that
    reaches it, after every frame decoded before it.

    With ``copies``, the thread also copies each frame, and `last_copy` hands over the
    copy of the frame ``next`` gave last: a frame's own array for whoever must hold one
    (an env's observation), made off the caller's thread.

    The thread is ``thread`` (a daemon, so that a decoder that never returns cannot keep
    the process alive); a read-ahead dropped without `close` stops it too, once
    collected.
    """

    def __init__(self, reader: VideoReader, depth: int = 2, limit: int | None = None,
                 join_timeout_s: float = 10.0, copies: bool = False) -> None:
        if depth < 1:
            raise ValueError(f"depth must be at least 1 frame, got {depth}")
        self.reader, self.limit, self.join_timeout_s = reader, limit, join_timeout_s
        self.copies = copies
        self._copy: np.ndarray | None = None
        self._queue: queue.Queue[Any] = queue.Queue(maxsize=depth)
        self._stop = threading.Event()
        self._finished = False
        # The thread holds no reference to this object, so that one dropped unclosed is
        # collected, and its __del__ stops the thread.
        self.thread = threading.Thread(
            target=_decode_ahead, args=(reader, self._queue, self._stop, limit, copies),
            name=f"decoding {reader.name}", daemon=True)
        self.thread.start()

    def __del__(self) -> None:
        self._stop.set()

    def __iter__(self) -> ReadAhead:
        return self

    def __next__(self) -> np.ndarray:
        if self._finished:
            raise StopIteration
        while True:
            try:
                item = self._queue.get(timeout=0.1)
                break
            except queue.Empty:
                if self.thread.is_alive():
                    continue
                try:  # the thread may have handed its last item over just now
                    item = self._queue.get_nowait()
                    break
                except queue.Empty:  # closed: nothing more comes
                    self._finished = True
                    raise StopIteration from None
        if isinstance(item, tuple):
            frame, self._copy = item
            return frame
        self._finished = True
        if isinstance(item, _Failed):
            raise item.error
        raise StopIteration

    def last_copy(self) -> np.ndarray | None:
        """With ``copies``: the copy of the frame ``next`` gave last, made on the thread;
        None without ``copies`` or once handed over."""
        copy, self._copy = self._copy, None
        return copy

    def close(self) -> None:
        """Stop decoding, drop the frames decoded ahead and wait (at most
        ``join_timeout_s``) for the thread, which releases the capture."""
        self._finished = True
        self._copy = None
        self._stop.set()
        while True:
            try:
                self._queue.get_nowait()
            except queue.Empty:
                break
        if self.thread is not threading.current_thread():
            self.thread.join(timeout=self.join_timeout_s)


def _decodes_cleanly(path: Path, timeout_s: float = 600.0) -> bool:
    """Whether ffmpeg decodes the first video stream of ``path`` to its end without an
    error (a decode that outlasts ``timeout_s`` counts as failed)."""
    import imageio_ffmpeg

    try:
        done = subprocess.run([imageio_ffmpeg.get_ffmpeg_exe(), "-nostdin", "-v", "error",
                               "-i", str(path), "-map", "0:v:0", "-f", "null", "-"],
                              capture_output=True, timeout=timeout_s)
    except (OSError, subprocess.TimeoutExpired):
        return False
    return done.returncode == 0 and not done.stderr.strip()


def require_frames(count: int, needed: int, source: str, why: str) -> None:
    """Raise `VideoFormatError` naming ``source`` when it has fewer than ``needed`` frames."""
    if count < needed:
        raise VideoFormatError(
            f"{source} has {count} frames, fewer than the {needed} that {why} needs"
        )


def video_meta(reader: VideoReader, n_links: int, reference_direction: float,
               joint_ranges: Sequence[tuple[float, float]]) -> dict[str, Any]:
    """A video clip's ``meta``: where it came from and the geometry a robot is built from."""
    if len(joint_ranges) != n_links:
        raise ValueError(f"joint_ranges needs one (low, high) per link ({n_links}), "
                         f"got {len(joint_ranges)}")
    return {
        "source": "camera" if reader.live else "video",
        "path": reader.name,
        "scenario": Path(reader.name).stem if not reader.live else reader.name,
        "seed": 0,
        "n_links": n_links,
        "demonstrator": "human",
        "reference_direction": float(reference_direction),
        "joint_ranges": [[float(lo), float(hi)] for lo, hi in joint_ranges],
        "arm_plane": "vertical",
    }


class FrameStream:
    """The frames of a `VideoReader` as an array-like for `Clip.frames`, read on demand.

    Indexing must move forward: frame i is read when first asked for, and only the last
    ``buffer`` frames are kept, so memory stays bounded however long the stream runs.
    Asking for a frame that has left the buffer raises IndexError (a live stream cannot
    rewind); asking past the end raises `StreamEndedError`; after the reading failed
    (`VideoFormatError`, say), asking for a frame not read raises that error again.
    ``len()`` is the container's frame count (capped at ``max_frames``), else
    ``max_frames``, else `UNBOUNDED`
    (``length_known`` is False: a live camera runs until it stops; ``cut_short`` is True
    when ``max_frames`` set the length); a stream may end sooner (a truncated file's
    container may promise more frames than it holds). The first frame is read on
    construction (it fixes the shape); if that fails, the reader is closed.

    ``read_ahead``: frames of a file decoded ahead on a thread (`ReadAhead`, never past
    the length, each with a copy for `fresh`); 0, or a live source (a camera, a URL),
    reads each frame when asked for. A live source's buffered frames keep their
    `StreamClock` (`clock`); after `keep_live`, frames that queued up at the source
    (a start-up, a loop slower than the source) are passed over.
    """

    dtype = np.dtype(np.uint8)
    ndim = 4

    def __init__(self, reader: VideoReader, buffer: int = 32,
                 max_frames: int | None = None, read_ahead: int = 2) -> None:
        self.reader = reader
        self._iterator: Generator[np.ndarray, None, None] | ReadAhead | None = None
        try:
            if buffer < 2:
                raise ValueError(f"buffer must hold at least 2 frames, got {buffer}")
            if read_ahead < 0:
                raise ValueError(f"read_ahead must be 0 or more frames, got {read_ahead}")
            reader.open()
            limit = reader.frame_count if reader.frame_count is not None else max_frames
            if limit is not None and max_frames is not None:
                limit = min(limit, max_frames)
            self.length_known = limit is not None
            self._length = max(1, limit) if limit is not None else UNBOUNDED
            # True when max_frames, not the end of the source, sets the length.
            self.cut_short = max_frames is not None and (reader.frame_count is None
                                                         or max_frames < reader.frame_count)
            self._frames: deque[np.ndarray] = deque(maxlen=buffer)
            self._copies: dict[int, np.ndarray] = {}  # `fresh`'s, by frame index
            self._clocks: dict[int, StreamClock] = {}  # a live source's, by frame index
            self.live_now = False  # `keep_live`
            self.passed_over = 0
            self._next_index = 0
            self.ended = False
            self._failed: Exception | None = None  # the reading's error, raised again
            self._iterator = (ReadAhead(reader, read_ahead, limit=limit, copies=True)
                              if read_ahead and not reader.live else iter(reader))
            self._pull()
        except BaseException:
            self.close()
            raise
        self.shape = (self._length, *self._frames[0].shape)

    def _pull(self) -> bool:
        assert self._iterator is not None
        if self._failed is not None:
            raise self._failed
        try:
            self._frames.append(next(self._iterator))
        except StopIteration:
            self.ended = True
            return False
        except Exception as error:
            self._failed = error
            raise
        if isinstance(self._iterator, ReadAhead):
            copy = self._iterator.last_copy()
            if copy is not None:
                self._copies[self._next_index] = copy
                self._copies.pop(self._next_index - _COPIES_KEPT, None)
        elif self.reader.live:
            self._clocks.pop(self._next_index - (self._frames.maxlen or 0), None)
            if self.reader.last_clock is not None:
                self._clocks[self._next_index] = self.reader.last_clock
        self._next_index += 1
        if self.live_now and self.reader.behind_s() > MAX_BEHIND_S:
            self._skip(None)
        return True

    def clock(self, index: int) -> StreamClock | None:
        """A live source's frame ``index``: when it was read and the stream's time for
        it, while it is buffered; None for a file, a frame gone from the buffer, or a
        source that keeps no clock."""
        return self._clocks.get(index)

    def keep_live(self) -> int:
        """From now on, read a live source as a robot must: the picture of now.

        First, if only frame 0 has been read, it is replaced by the newest frame,
        passing over those that queued up since it was read (the models loading, a
        robot's bus opening) and those that were waiting already (up to `START_DRAIN_S`
        of them; see `VideoReader.skip_queued`). Then each frame read over
        `MAX_BEHIND_S` behind the stream's pace (`VideoReader.behind_s`: a loop slower
        than the source) is replaced by the newest. The frames passed over are never
        seen: the frames kept follow one another as if consecutive. ``passed_over``
        counts them. Returns how many were passed over now; does nothing for a file or
        a source without a clock."""
        if not self.reader.live or self.reader.last_clock is None:
            return 0
        self.live_now = True
        since = self._clocks.get(0)
        if since is None or self._next_index != 1 or self.ended or self._failed is not None:
            return 0
        return self._skip(since.read_at - since.stream_s, START_DRAIN_S)

    def _skip(self, reference: float | None, drain_s: float = 0.0) -> int:
        """The last frame read replaced by the newest (`VideoReader.skip_queued`)."""
        dropped = self.reader.dropped_frames
        try:
            newest = self.reader.skip_queued(reference, drain_s)
        except Exception as error:
            self._failed = error
            raise
        index = self._next_index - 1
        if newest is not None:
            self._frames[-1] = newest
            if self.reader.last_clock is not None:
                self._clocks[index] = self.reader.last_clock
            else:
                self._clocks.pop(index, None)
        passed = self.reader.dropped_frames - dropped
        self.passed_over += passed
        return passed

    def fresh(self, index: int) -> np.ndarray:
        """Frame ``index`` (as ``self[index]``) in an array of its own that nothing else
        holds, such as an observation must be: for a file read ahead, the copy its
        decoding thread made (the first time this frame is asked for this way, while it
        is among the last few read); else a copy made now."""
        frame = self[index]
        copy = self._copies.pop(index, None)
        return frame.copy() if copy is None else copy

    def __len__(self) -> int:
        return self._length

    @property
    def frames_read(self) -> int:
        """How many frames have come from the source so far (asked for, or decoded
        ahead and handed over)."""
        return self._next_index

    def __getitem__(self, index: int) -> np.ndarray:
        if not isinstance(index, (int, np.integer)) or index < 0:
            raise TypeError(f"a FrameStream takes non-negative int indices, got {index!r}")
        if index >= self._length:
            raise StreamEndedError(f"{self.reader.name}: frame {index} is past the end")
        while index >= self._next_index:
            if not self._pull():
                raise StreamEndedError(
                    f"{self.reader.name} ended after {self._next_index} frames")
        oldest = self._next_index - len(self._frames)
        if index < oldest:
            raise IndexError(f"{self.reader.name}: frame {index} has left the stream's buffer "
                             f"(frames {oldest}-{self._next_index - 1}); a stream cannot rewind")
        if index == self._length - 1:
            self.close()  # the last frame: release the capture now, not at garbage collection
        return self._frames[index - oldest]

    def __iter__(self) -> Iterator[np.ndarray]:
        """The frames from the oldest one still buffered to the end of the stream."""
        index = self._next_index - len(self._frames)
        while index < self._length:
            try:
                yield self[index]
            except StreamEndedError:
                return
            index += 1

    def close(self) -> None:
        """Stop reading and release the capture (also done when the stream ends; a
        `ReadAhead`'s thread releases it itself)."""
        if self._iterator is not None:
            self._iterator.close()
        if not isinstance(self._iterator, ReadAhead):
            self.reader.close()


def stream_video(
    source: str | int | Path,
    *,
    n_links: int = 1,
    reference_direction: float = DEFAULT_REFERENCE_DIRECTION,
    joint_ranges: Sequence[tuple[float, float]] | None = None,
    fps: float | None = None,
    max_frames: int | None = None,
    max_seconds: float | None = None,
    buffer: int = 32,
    read_ahead: int = 2,
) -> Clip:
    """A `Clip` over a file, camera or URL whose frames are a `FrameStream`: bounded
    memory, forward-only, no truth. Arguments as in `load_video`; ``max_frames`` bounds
    the run, as does ``max_seconds`` of footage at the source's fps (a live source
    without either runs until it stops); ``buffer`` and ``read_ahead`` as in
    `FrameStream`. Close it with ``clip.frames.close()`` (the capture is also released
    when the stream ends)."""
    ranges = tuple(joint_ranges) if joint_ranges is not None else (DEFAULT_JOINT_RANGE,) * n_links
    # A file decoded ahead needs no decoding threads of FFmpeg's own (decode_threads).
    reader = VideoReader(source, fps=fps,
                         decode_threads=1 if read_ahead and not _is_live(source) else None
                         ).open()
    if max_seconds is not None:
        limit = max(1, round(max_seconds * reader.fps))
        max_frames = limit if max_frames is None else min(max_frames, limit)
    frames = FrameStream(reader, buffer=buffer, max_frames=max_frames,
                         read_ahead=read_ahead)  # closes the reader if it fails
    meta = video_meta(reader, n_links, reference_direction, ranges)
    return Clip(frames=frames, fps=reader.fps, meta=meta)  # type: ignore[arg-type]
