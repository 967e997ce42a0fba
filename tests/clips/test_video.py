"""Video files as clip sources: real OpenCV encoding and decoding, no mocks."""

import json
import math
import threading
import time

import cv2
import gymnasium as gym
import numpy as np
import pytest

from imimic_gym.clips.annotations import AnnotationError, truth_from_coco
from imimic_gym.clips.cache import load_clip
from imimic_gym.clips.scenarios import get_scenario
from imimic_gym.clips.video import (
    ReadAhead,
    StreamEndedError,
    VideoFormatError,
    VideoOpenError,
    VideoReader,
    require_frames,
    stream_video,
)
from imimic_gym.clips.video_load import load_video
from imimic_gym.clips.video_writer import write_video
from imimic_gym.estimators.don.one_link import DON
from imimic_gym.metrics import angle_rmse_deg
from tests.processes import stop, stream_live

WARM_UP = 15  # frames: DON sees nothing before the arm has moved


def don_rmse(frames, clip) -> float:
    don = DON(fps=clip.fps, reference_direction=clip.meta["reference_direction"],
              joint_range=tuple(clip.meta["joint_ranges"][0]))
    angles = np.array([e.angles for e in don.run(frames)])
    return angle_rmse_deg(angles[WARM_UP:], clip.truth.angles[WARM_UP:])


def test_mp4_round_trip_keeps_dons_accuracy(servo_clip, servo_mp4) -> None:
    video = load_video(servo_mp4)
    assert video.frames.shape == servo_clip.frames.shape and video.fps == 30.0
    assert video.meta["skipped_frames"] == 0 and video.meta["source"] == "video"
    # mp4v is lossy: close to the rendered pixels, not equal (measured 1.67 grey levels).
    assert 0 < np.abs(video.frames.astype(int) - servo_clip.frames).mean() < 3.5
    in_memory, decoded = don_rmse(servo_clip.frames, servo_clip), don_rmse(video.frames,
                                                                            servo_clip)
    # measured 0.64 deg, 0.74 decoded (issue 40: about 2x, and a floor of 0.05)
    assert in_memory < 1.3
    assert abs(decoded - in_memory) < 0.25


def test_fps_is_the_containers_float(tmp_path) -> None:
    frames = np.zeros((4, 24, 32, 3), dtype=np.uint8)
    path = write_video(tmp_path / "ntsc.mp4", frames, 30000 / 1001)
    with VideoReader(path) as video:
        assert video.fps == pytest.approx(29.97, abs=1e-3) and isinstance(video.fps, float)
    assert load_video(path).fps == pytest.approx(29.97, abs=1e-3)


def test_a_stream_holds_a_bounded_buffer_and_reads_forward(servo_clip, servo_mp4) -> None:
    clip = stream_video(servo_mp4, buffer=4)
    stream = clip.frames
    assert len(clip) == len(servo_clip) and clip.fps == 30.0
    decoded = load_video(servo_mp4).frames
    np.testing.assert_array_equal(stream[10], decoded[10])
    np.testing.assert_array_equal(stream[12], decoded[12])
    assert len(stream._frames) == 4
    with pytest.raises(IndexError, match="has left the stream's buffer"):
        stream[5]
    assert sum(1 for _ in stream) == len(servo_clip) - 9  # from frame 9, the buffer's oldest
    with pytest.raises(StreamEndedError, match="past the end"):
        stream[len(servo_clip)]
    assert stream.reader.capture is None  # released at the end


def test_reading_stopped_early_releases_the_capture(servo_mp4) -> None:
    reader = VideoReader(servo_mp4)
    frames = iter(reader)
    next(frames)
    assert reader.capture is not None
    frames.close()
    assert reader.capture is None


def decoding_threads(source) -> list[threading.Thread]:
    """`ReadAhead` threads still running on ``source`` (each is named "decoding <source>")."""
    return [t for t in threading.enumerate() if t.name == f"decoding {source}"]


def test_read_ahead_gives_a_plain_decodes_frames_in_order(servo_mp4) -> None:
    plain = list(VideoReader(servo_mp4))
    reader = VideoReader(servo_mp4)
    ahead = list(ReadAhead(reader, depth=2))
    assert len(ahead) == len(plain) == 90
    for mine, theirs in zip(ahead, plain, strict=True):
        np.testing.assert_array_equal(mine, theirs)
    assert reader.frames_read == 90 and reader.capture is None  # released by its thread
    with_copies = ReadAhead(VideoReader(servo_mp4), depth=2, copies=True)
    for index in range(3):
        frame = next(with_copies)
        copy = with_copies.last_copy()
        np.testing.assert_array_equal(copy, plain[index])
        assert not np.shares_memory(copy, frame) and with_copies.last_copy() is None
    with_copies.close()
    # The streamed clip, indexed as the env does, holds the same frames.
    clip = stream_video(servo_mp4)
    for index in (0, 1, 2, 45, 89):
        np.testing.assert_array_equal(clip.frames[index], plain[index])
    assert clip.frames.reader.capture is None and not decoding_threads(servo_mp4)


def test_one_decoding_thread_gives_the_same_frames(servo_mp4) -> None:
    default = list(VideoReader(servo_mp4))
    alone = VideoReader(servo_mp4, decode_threads=1)
    for mine, theirs in zip(alone, default, strict=True):
        np.testing.assert_array_equal(mine, theirs)
    with pytest.raises(ValueError, match="decode_threads must be at least 1, got 0"):
        VideoReader(servo_mp4, decode_threads=0)


def test_read_ahead_stops_at_the_length_asked_for(servo_mp4) -> None:
    clip = stream_video(servo_mp4, max_frames=5)
    assert len(clip) == 5 and clip.frames.cut_short
    assert sum(1 for _ in clip.frames) == 5
    # Not one frame decoded past the end asked for (what a plain read would do).
    assert clip.frames.reader.frames_read == 5 and clip.frames.reader.capture is None


def test_closing_a_read_ahead_stops_its_thread_and_releases_the_capture(servo_mp4) -> None:
    reader = VideoReader(servo_mp4)
    frames = ReadAhead(reader, depth=2, join_timeout_s=30.0)
    first = [next(frames) for _ in range(3)]
    np.testing.assert_array_equal(first[2], list(VideoReader(servo_mp4))[2])
    frames.close()
    assert not frames.thread.is_alive() and reader.capture is None
    assert next(frames, None) is None  # a closed read-ahead gives nothing more
    # A stream closed mid-run, as mimic's Ctrl-C closes it.
    clip = stream_video(servo_mp4)
    clip.frames[10]
    clip.frames.close()
    assert clip.frames.reader.capture is None and not decoding_threads(servo_mp4)


def test_a_read_ahead_dropped_unclosed_stops_once_collected(servo_mp4) -> None:
    import gc

    reader = VideoReader(servo_mp4)
    frames = ReadAhead(reader, depth=2)
    next(frames)
    thread = frames.thread
    del frames
    gc.collect()
    thread.join(timeout=30)
    assert not thread.is_alive() and reader.capture is None


def test_a_decoding_error_comes_after_the_frames_before_it_and_stops_the_thread(
        tmp_path) -> None:
    for i in range(6):
        size = (30, 40) if i < 4 else (50, 60)
        cv2.imwrite(str(tmp_path / f"frame_{i:03d}.png"), np.full((*size, 3), 40 * i, np.uint8))
    reader = VideoReader(tmp_path / "frame_%03d.png", fps=25.0)
    frames = ReadAhead(reader, depth=2, join_timeout_s=30.0)
    assert [int(next(frames)[0, 0, 0]) for _ in range(4)] == [0, 40, 80, 120]
    with pytest.raises(VideoFormatError,
                       match=r"frame_%03d\.png: frame 4 is 60x50 but the video started at 40x30"):
        next(frames)
    frames.thread.join(timeout=30)
    assert not frames.thread.is_alive() and reader.capture is None
    frames.close()  # closing after the end is harmless


def test_a_file_without_a_frame_fails_in_stream_video_with_no_thread_left(tmp_path) -> None:
    path = tmp_path / "zero.avi"
    cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 30.0, (64, 48)).release()
    with pytest.raises(VideoFormatError, match=r"zero\.avi has no frames that can be decoded"):
        stream_video(path)
    assert not decoding_threads(path)
    (tmp_path / "notes.mp4").write_text("not a video " * 50)
    with pytest.raises(VideoOpenError, match=r"notes\.mp4: OpenCV cannot decode it"):
        stream_video(tmp_path / "notes.mp4")
    assert not decoding_threads(tmp_path / "notes.mp4")


def test_fresh_frames_are_the_frames_in_arrays_of_their_own(servo_mp4) -> None:
    plain = list(VideoReader(servo_mp4))
    for read_ahead in (2, 0):  # copied on the decoding thread, or when asked for
        stream = stream_video(servo_mp4, read_ahead=read_ahead).frames
        for index in range(6):
            frame = stream.fresh(index)
            np.testing.assert_array_equal(frame, plain[index])
            assert not np.shares_memory(frame, stream[index])
            again = stream.fresh(index)  # asked twice: another array of its own
            np.testing.assert_array_equal(again, plain[index])
            assert not np.shares_memory(again, frame)
        stream.close()


def test_a_streamed_envs_observation_is_its_own_array(servo_mp4) -> None:
    plain = list(VideoReader(servo_mp4))
    clip = stream_video(servo_mp4, max_frames=5)
    env = gym.make("ImitateVideo-v0", clip=clip)
    seen = [env.reset(seed=0)[0]["frame"]]
    for _ in range(3):
        seen.append(env.step(np.zeros(1, np.float32))[0]["frame"])
    for index, frame in enumerate(seen):
        np.testing.assert_array_equal(frame, plain[index])
        assert not np.shares_memory(frame, clip.frames[index])
    seen[1][:] = 0  # the caller's to change: the stream's frame stays as decoded
    np.testing.assert_array_equal(clip.frames[1], plain[1])
    env.close()
    clip.frames.close()


def test_a_live_source_is_read_when_asked_for(servo_mp4) -> None:
    # A URL, like a camera: each frame is the newest the source has, none decoded ahead.
    clip = stream_video(f"file://{servo_mp4}")
    assert clip.meta["source"] == "camera"
    clip.frames[3]
    assert clip.frames.reader.frames_read == 4 and not decoding_threads(f"file://{servo_mp4}")
    clip.frames.close()


def test_a_live_source_kept_live_passes_over_frames_read_late(servo_mp4) -> None:
    # A file:// URL is a live source to the reader, whose frames are all there at once:
    # read late against the stream's clock, it is what a camera read by a slow loop is.
    clip = stream_video(f"file://{servo_mp4}")
    frames = clip.frames
    assert frames.clock(0) is not None and frames.clock(0).stream_s == 0.0
    frames.keep_live()
    before = frames.passed_over
    time.sleep(0.5)  # a slow step: frame 1 is read 0.5 s after frame 0
    frames[1]
    passed = frames.passed_over - before
    assert passed >= 1  # frame 1 is a later frame of the stream, the ones between gone
    assert frames.clock(1).stream_s == pytest.approx((before + passed + 1) / clip.fps,
                                                     abs=2e-3)
    assert frames.reader.dropped_frames == frames.passed_over
    frames.close()
    # A file, or a stream not kept live, is read frame by frame however slowly.
    second = list(VideoReader(servo_mp4))[1]
    for source, keep in ((servo_mp4, True), (f"file://{servo_mp4}", False)):
        clip = stream_video(source)
        if keep:
            assert clip.frames.keep_live() == 0
        time.sleep(0.2)
        np.testing.assert_array_equal(clip.frames[1], second)
        assert clip.frames.passed_over == 0
        clip.frames.close()


def test_a_live_stream_kept_live_starts_on_the_frame_of_now(servo_mp4) -> None:
    # ffmpeg sends the clip at its own rate over TCP, as an IP camera does; frame 0 is
    # read on opening, then the run's start-up (1 s here) lets frames queue up.
    player, url = stream_live(servo_mp4)
    try:
        clip = stream_video(url)
        time.sleep(1.0)
        passed = clip.frames.keep_live()
        assert passed >= 1 and clip.frames.passed_over == passed
        # Frame 0 is now the frame after the last one passed over (the old frame 0 too).
        assert clip.frames.clock(0).stream_s == pytest.approx(passed / clip.fps, abs=2e-3)
        clip.frames[1]
        assert clip.frames.clock(1).stream_s > clip.frames.clock(0).stream_s
        clip.frames.close()
    finally:
        stop(player)


class StallingStream:
    """Stands in for OpenCV's capture of a network stream (the edge this project does not
    own): frame k, stamped k / 30 s, arrives at k / 30 s after the start, and from frame
    30 on everything arrives ``stall`` seconds late (a network that stalled once). A
    grab waits for its frame's arrival as a socket read does."""

    def __init__(self, stall: float) -> None:
        self.stall, self.start, self.k = stall, time.perf_counter(), -1

    def grab(self) -> bool:
        self.k += 1
        arrival = self.start + self.k / 30.0 + (self.stall if self.k >= 30 else 0.0)
        time.sleep(max(arrival - time.perf_counter(), 0.0))
        return True

    def retrieve(self) -> tuple[bool, np.ndarray]:
        return True, np.full((8, 8, 3), self.k % 256, np.uint8)

    def read(self) -> tuple[bool, np.ndarray]:
        self.grab()
        return self.retrieve()

    def get(self, prop: int) -> float:
        return 1000.0 * self.k / 30.0 if prop == cv2.CAP_PROP_POS_MSEC else 0.0

    def release(self) -> None:
        pass


def test_a_stalled_stream_is_not_chased_frame_after_frame() -> None:
    # After a 2 s stall every frame comes 2 s later than the stream's clock says: the
    # loop is behind, so the queue is skipped, but the first frame it has to wait for
    # ends the skip and becomes the reference. Without that the skip would wait for frame
    # after frame, up to MAX_SKIP_S of them, while the robot got no command.
    reader = VideoReader("tcp://127.0.0.1:9")  # a URL: live; nothing is opened
    reader.capture, reader.fps, reader.frame_count = StallingStream(2.0), 30.0, None
    frames = iter(reader)
    for _ in range(31):  # frames 0-29 as they come, then frame 30, 2 s late
        next(frames)
    assert reader.behind_s() == pytest.approx(2.0, abs=0.25)
    started = time.perf_counter()
    newest = reader.skip_queued()
    assert newest is not None and time.perf_counter() - started < 1.0
    assert 1 <= reader.dropped_frames <= 5
    assert reader.behind_s() == 0.0  # the frame waited for is the reference now
    frames.close()


def test_missing_empty_and_undecodable_files_are_named(tmp_path) -> None:
    with pytest.raises(VideoOpenError, match=r"cannot open video .*nope\.mp4: no such file"):
        load_video(tmp_path / "nope.mp4")
    (tmp_path / "empty.mp4").write_bytes(b"")
    with pytest.raises(VideoOpenError, match=r"empty\.mp4: the file is empty"):
        load_video(tmp_path / "empty.mp4")
    (tmp_path / "notes.mp4").write_text("not a video " * 50)
    with pytest.raises(VideoOpenError, match=r"notes\.mp4: OpenCV cannot decode it"):
        load_video(tmp_path / "notes.mp4")
    with pytest.raises(OSError, match="it is a directory"):
        load_video(tmp_path)


def test_a_video_with_zero_frames_is_named(tmp_path) -> None:
    path = tmp_path / "zero.avi"
    cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 30.0, (64, 48)).release()
    with pytest.raises(VideoFormatError, match=r"zero\.avi has no frames that can be decoded"):
        load_video(path)


def test_a_resolution_change_mid_stream_is_named(tmp_path) -> None:
    # An image sequence: OpenCV's image backend returns every image at its own size.
    for i in range(6):
        size = (30, 40) if i < 4 else (50, 60)
        cv2.imwrite(str(tmp_path / f"frame_{i:03d}.png"), np.full((*size, 3), 40 * i, np.uint8))
    reader = VideoReader(tmp_path / "frame_%03d.png", fps=25.0)
    with pytest.raises(VideoFormatError,
                       match=r"frame_%03d\.png: frame 4 is 60x50 but the video started at 40x30"):
        list(reader)
    assert reader.capture is None  # released although the iteration raised


def test_a_streams_error_is_raised_again_for_every_later_frame(tmp_path) -> None:
    """A frame peeked ahead (`ImitateVideoEnv.upcoming_frame`) cannot swallow the reading's
    error: the stream raises it again, so the step to that frame still fails with it."""
    for i in range(6):
        size = (30, 40) if i < 4 else (50, 60)
        cv2.imwrite(str(tmp_path / f"frame_{i:03d}.png"), np.full((*size, 3), 40 * i, np.uint8))
    message = r"frame 4 is 60x50 but the video started at 40x30"
    stream = stream_video(tmp_path / "frame_%03d.png", fps=25.0).frames
    stream[3]
    for _ in range(2):
        with pytest.raises(VideoFormatError, match=message):
            stream[4]
    env = gym.make("ImitateVideo-v0", clip=stream_video(tmp_path / "frame_%03d.png", fps=25.0))
    env.reset(seed=0)
    for _ in range(3):
        env.step(np.zeros(1, np.float32))
    assert env.unwrapped.upcoming_frame() is None  # frame 4 fails to read: not known
    with pytest.raises(VideoFormatError, match=message):
        env.step(np.zeros(1, np.float32))
    env.close()


def test_an_image_sequence_needs_a_frame_rate(tmp_path) -> None:
    cv2.imwrite(str(tmp_path / "f_000.png"), np.zeros((8, 8, 3), np.uint8))
    with pytest.raises(VideoFormatError, match=r"f_%03d\.png does not report its frame rate"):
        load_video(tmp_path / "f_%03d.png")


def jpeg(value: int) -> bytes:
    image = np.full((48, 64, 3), value, np.uint8)
    image[:24] = 255 - value
    return cv2.imencode(".jpg", image)[1].tobytes()


def test_a_corrupt_frame_in_the_middle_is_skipped_and_counted(tmp_path) -> None:
    good = [jpeg(20 * i) for i in range(8)]
    broken = b"\xff\xd8\xff\xe0" + bytes(100) + b"\xff\xd9"  # a JPEG with no image in it
    path = tmp_path / "motion.mjpeg"
    path.write_bytes(b"".join([*good[:3], broken, *good[3:]]))
    clip = load_video(path, fps=25.0)
    assert len(clip) == 8 and clip.meta["skipped_frames"] == 1
    # The frames around the broken one are the real ones, in order.
    assert clip.frames[3, 40, 0, 0] == pytest.approx(60, abs=3)


def test_too_short_for_a_window_is_named() -> None:
    with pytest.raises(VideoFormatError, match=r"clip\.mp4 has 7 frames, fewer than the 11 "
                                               r"that DON \(window 10\) needs"):
        require_frames(7, 11, "clip.mp4", "DON (window 10)")
    require_frames(11, 11, "clip.mp4", "DON (window 10)")


def coco_file(path, keypoints: np.ndarray, prefix: str = "right_") -> None:
    """COCO keypoints for (T, 3, 2) shoulder, elbow, wrist pixels, 17-keypoint layout."""
    names = ["nose", "left_eye", "right_eye", "left_ear", "right_ear", "left_shoulder",
             "right_shoulder", "left_elbow", "right_elbow", "left_wrist", "right_wrist",
             "left_hip", "right_hip", "left_knee", "right_knee", "left_ankle", "right_ankle"]
    columns = [names.index(prefix + n) for n in ("shoulder", "elbow", "wrist")]
    annotations = []
    for t, points in enumerate(keypoints):
        flat = np.zeros((17, 3))
        flat[columns, :2], flat[columns, 2] = points, 2
        annotations.append({"id": t, "image_id": 100 + t, "category_id": 1,
                            "keypoints": flat.ravel().tolist()})
    path.write_text(json.dumps({
        "images": [{"id": 100 + t, "file_name": f"{t}.jpg"} for t in range(len(keypoints))],
        "annotations": annotations,
        "categories": [{"id": 1, "name": "person", "keypoints": names}],
    }))


def test_coco_keypoints_give_the_true_elbow_angle(tmp_path) -> None:
    clip = load_clip(get_scenario("default", n_frames=30), progress=False)
    names = list(clip.truth.keypoint_names)
    arm = clip.truth.keypoints[:, [names.index(n) for n in ("shoulder", "elbow", "wrist")]]
    coco_file(tmp_path / "arm.json", arm)
    truth = truth_from_coco(tmp_path / "arm.json", len(clip), clip.fps, n_links=1,
                            reference_direction=0.0)
    # The forearm's angle from the upper arm, from pixels alone: measured 7e-6 deg, the
    # round-off of the truth's float32 keypoints (issue 40: a floor of 0.001).
    assert angle_rmse_deg(truth.angles, clip.truth.angles) < 0.001
    assert truth.visible.all() and truth.angles.shape == (30, 1)


def test_unlabelled_frames_are_interpolated_and_marked(tmp_path) -> None:
    t = np.arange(5)
    elbow = np.radians(10.0 * t)  # the forearm turns 10 degrees a frame from straight down
    shoulder, joint = np.array([100.0, 50.0]), np.array([100.0, 100.0])
    wrist = joint + 40 * np.stack([np.sin(elbow), np.cos(elbow)], axis=1)
    keypoints = np.stack([np.tile(shoulder, (5, 1)), np.tile(joint, (5, 1)), wrist], axis=1)
    coco_file(tmp_path / "a.json", keypoints, prefix="left_")
    data = json.loads((tmp_path / "a.json").read_text())
    data["annotations"].pop(2)
    (tmp_path / "a.json").write_text(json.dumps(data))
    truth = truth_from_coco(tmp_path / "a.json", 5, 30.0, n_links=1,
                            reference_direction=-math.pi / 2)
    np.testing.assert_allclose(np.degrees(truth.angles[:, 0]), [0, 10, 20, 30, 40], atol=1e-4)
    assert not truth.visible[2].any() and truth.visible[3].all()
    assert np.degrees(truth.angular_velocity[2, 0]) == pytest.approx(300.0)
    # Two links: the upper arm hangs straight down (q1 = 0 from the torso's axis), then
    # the elbow as before.
    two = truth_from_coco(tmp_path / "a.json", 5, 30.0, n_links=2,
                          reference_direction=-math.pi / 2)
    np.testing.assert_allclose(np.degrees(two.angles), [[0, 10 * k] for k in range(5)],
                               atol=1e-4)


def test_bad_annotation_files_are_named(tmp_path) -> None:
    with pytest.raises(AnnotationError, match=r"missing\.json: no such annotation file"):
        truth_from_coco(tmp_path / "missing.json", 5, 30.0, 1, 0.0)
    (tmp_path / "x.json").write_text('{"images": []}')
    with pytest.raises(AnnotationError, match=r"x\.json is not COCO keypoints"):
        truth_from_coco(tmp_path / "x.json", 5, 30.0, 1, 0.0)
    coco_file(tmp_path / "long.json", np.zeros((9, 3, 2)))
    with pytest.raises(AnnotationError, match=r"long\.json annotates frame 8, but the video "
                                              r"has 5 frames"):
        truth_from_coco(tmp_path / "long.json", 5, 30.0, 1, 0.0)


def test_env_runs_a_video_with_and_without_annotations(servo_clip, servo_mp4, tmp_path) -> None:
    env = gym.make("ImitateVideo-v0", clip=str(servo_mp4))
    obs, info = env.reset(seed=0)
    assert obs["frame"].shape == (240, 320, 3) and info["has_truth"] is False
    _, reward, _, _, info = env.step(np.zeros(1, dtype=np.float32))
    assert info["reward_tracking"] == 0.0 and reward == info["reward_ctrl"]
    assert "tracking_error_deg" not in info and "target_angles" not in info
    with pytest.raises(ValueError, match=r"servo\.mp4 has no ground truth"):
        env.unwrapped.target_angles(1)
    # The default geometry: reference down the image, the paper's 120-degree servo range.
    inner = env.unwrapped
    assert inner.arm.reference_direction == pytest.approx(-math.pi / 2)
    np.testing.assert_allclose(np.degrees(inner.arm.joint_ranges[0]), [-60, 60])

    # The servo's pivot and tip, with a "shoulder" below the pivot: the upper arm then
    # points up the image, the servo's zero mark, and the elbow angle is the servo's.
    pivot, tip = servo_clip.truth.keypoints[:, 0], servo_clip.truth.keypoints[:, -1]
    below = pivot + np.array([0.0, 30.0], dtype=np.float32)
    coco_file(tmp_path / "servo.json", np.stack([below, pivot, tip], axis=1))
    env = gym.make("ImitateVideo-v0", clip=str(servo_mp4),
                   annotations=str(tmp_path / "servo.json"))
    _, info = env.reset(seed=0)
    assert info["has_truth"] is True and np.isfinite(info["tracking_error_deg"])
    truth = env.unwrapped.clip.truth.angles
    # measured 2e-6 deg: the round-off of float32 keypoints (issue 40: a floor of 0.001)
    assert angle_rmse_deg(truth, servo_clip.truth.angles) < 0.001
    _, reward, _, _, info = env.step(np.zeros(1, dtype=np.float32))
    assert info["reward_tracking"] < 0


def test_annotations_need_a_video_path(servo_clip) -> None:
    with pytest.raises(ValueError, match=r"annotations='a\.json' belong to a video"):
        gym.make("ImitateVideo-v0", clip=servo_clip, annotations="a.json")


def test_a_video_env_passes_gymnasiums_checker(servo_mp4) -> None:
    import warnings

    from gymnasium.utils.env_checker import check_env

    env = gym.make("ImitateVideo-v0", clip=str(servo_mp4), n_frames=20, render_mode="rgb_array")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(env.unwrapped)
    assert len(env.unwrapped.clip) == 20


def test_videos_are_written_as_h264_that_browsers_and_opencv_play(tmp_path) -> None:
    import imageio_ffmpeg

    frames = [np.full((41, 63, 3), 10 * i, np.uint8) for i in range(12)]  # odd sides
    path = write_video(tmp_path / "odd.mp4", iter(frames), 30.0)
    reader = imageio_ffmpeg.read_frames(str(path))
    meta = next(reader)
    reader.close()
    assert meta["codec"] == "h264" and tuple(meta["size"]) == (64, 42)  # padded to even
    back = list(VideoReader(path))
    assert len(back) == 12 and back[0].shape == (42, 64, 3)
    assert abs(int(back[5][:41, :63].mean()) - 50) <= 3


def test_without_imageio_ffmpeg_the_video_is_mp4v_with_a_warning(tmp_path, monkeypatch) -> None:
    from imimic_gym.clips import video_writer

    monkeypatch.setattr(video_writer, "_imageio_ffmpeg", lambda: None)
    frames = [np.zeros((24, 32, 3), np.uint8)] * 3
    with pytest.warns(UserWarning, match="browsers do not play"):
        path = write_video(tmp_path / "old.mp4", frames, 30.0)
    capture = cv2.VideoCapture(str(path))
    try:
        fourcc = int(capture.get(cv2.CAP_PROP_FOURCC))
        assert fourcc.to_bytes(4, "little") in (b"mp4v", b"FMP4")  # MPEG-4 part 2
    finally:
        capture.release()


def test_a_video_too_big_for_memory_is_refused_before_it_is_read(tmp_path, monkeypatch) -> None:
    frames = [np.full((48, 64, 3), 7 * i, np.uint8) for i in range(20)]
    path = write_video(tmp_path / "long.mp4", frames, 30.0)
    clip = load_video(path)  # 20 x 48 x 64 x 3 = 184 kB: within the default bound
    assert clip.frames.shape == (20, 48, 64, 3) and clip.frames.flags.owndata
    assert abs(int(clip.frames[10].mean()) - 70) <= 3
    assert load_video(path, max_frames=5).frames.shape[0] == 5
    monkeypatch.setenv("IMIMIC_VIDEO_MAX_GB", "0.0001")  # 100 kB
    with pytest.raises(VideoFormatError, match=r"20 frames of 64x48 take 0\.000184 GB in "
                                               r"memory, over the 0\.0001 GB bound"):
        load_video(path)
    assert load_video(path, max_frames=10).frames.shape[0] == 10  # 92 kB fits
