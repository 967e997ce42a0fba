"""Suite ``spatial``: the arm read in 3-D and copied by the SO-101.

Part ``estimators``: `pose3d` (the pose model's 2-D keypoints lifted with bone lengths),
`pose-world` (MediaPipe's own world landmarks, the baseline) and `pose3d-depth` (the
keypoints back-projected through the depth image, an RGB-D camera) on every spatial
scenario's test-pool clips against the rendered 3-D truth: elbow-flexion RMSE, forearm and
upper-arm direction errors (per clip: RMSE, median and 95th percentile over its frames;
over clips: mean with its 95% interval, and the worst clips), coverage. Part ``robot``:
the SO-101 of ``ImitateVideo3D-v0`` driven by the position controller from `pose3d` and
from the truth (the oracle), and by the learned tracker from the truth, its joint RMSE
against the retargeted truth. Part ``real``:
`pose3d` and `pose-world` on the real videos of ../shared/realdata (no 3-D truth there):
coverage, smoothness (median turn of the forearm between frames), flips (a bone's depth
sign changing while it points well out of the image plane), the flexion's spread. Part
``mimic``: `imimic mimic --robot so101` on a 1920x1080 H.264 clip, frames/s (the median
of `MIMIC_REPEATS` runs interleaved with the planar `imimic mimic`'s), beside the planar
`imimic mimic` and OpenCV's decode of the same clip in the same run. Part ``camera``: the
same with the clip as a live source: ffmpeg plays it at its own rate (``-re``, no
re-encoding) as an MPEG-TS stream on a local TCP port, as an IP camera sends one, and
`imimic mimic --camera tcp://...` reads it in a process of its own; the frames/s kept
against the stream's own, the frames passed over and how far the commands trailed the
frames' arrival.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from suites.pool import (
    QUICK_SEEDS,
    TEST_POOL,
    ci,
    pool_text,
    spread,
    sweep,
    table,
    work_folder,
    worst,
)

from imimic_gym.bench import machine
from imimic_gym.sweep import Cell

SCENARIOS = ("spatial-reach", "spatial-cup", "spatial-raise", "spatial-curl", "spatial-wave",
             "spatial")
ESTIMATORS = ("pose3d", "pose-world", "pose3d-depth")
# The robot part's runs: (estimator, controller).
ROBOT_RUNS = (("pose3d", "position"), ("oracle", "position"), ("oracle", "learned"))
KEYS = ("elbow_flexion_rmse_deg", "forearm_direction_error_deg",
        "forearm_direction_p95_deg", "upper_arm_direction_error_deg", "coverage",
        "arm_found", "elbow_2d_rmse_deg", "elbow_2d_across_rmse_deg")
PARTS = ("estimators", "robot", "real", "mimic", "camera")
MIMIC_REPEATS = 5  # runs of each mimic, interleaved; the median is reported
REALDATA = Path(__file__).resolve().parents[2].parent / "shared" / "realdata"
# The targets for pose3d on RGB (test pool): flexion RMSE, forearm median (deg).
TARGETS = {"elbow_flexion_rmse_deg": 6.0, "forearm_direction_error_deg": 8.0}


def run(args: Any) -> dict[str, Any]:
    parts = args.parts or PARTS
    seeds = QUICK_SEEDS if args.quick else TEST_POOL
    data: dict[str, Any] = {"machine": machine(), "quick": bool(args.quick),
                            "seeds": list(seeds)}
    suffix = ".quick" if args.quick else ""
    if "estimators" in parts:
        cells = [Cell(s, e, None, seed) for s in SCENARIOS for e in ESTIMATORS
                 for seed in seeds]
        results = sweep("spatial" + suffix, cells, args)
        data["estimators"] = [
            {"scenario": r["scenario"], "estimator": r["estimator"], "clips": r["episodes"],
             **{key: spread([row for row in r["rows"] if row.get(key) is not None], key)
                for key in KEYS},
             "per_clip": r["rows"]} for r in results]
    if "robot" in parts:
        cells = [Cell(s, e, c, seed) for s in SCENARIOS for e, c in ROBOT_RUNS
                 for seed in seeds]
        results = sweep("spatial.robot" + suffix, cells, args)
        data["robot"] = [{"scenario": r["scenario"], "estimator": r["estimator"],
                          "controller": r["controller"], "clips": r["episodes"],
                          "rmse_deg": spread(r["rows"], "rmse_deg"),
                          "per_clip": r["rows"]} for r in results]
    if "real" in parts:
        data["real"] = real(args.quick)
    if "mimic" in parts:
        data["mimic"] = mimic(args.quick)
    if "camera" in parts:
        data["camera"] = camera(args.quick)
    return data


def real(quick: bool) -> dict[str, Any]:
    """`pose3d` and `pose-world` over every real video (evaluation and development
    clips; nothing is chosen here): coverage, smoothness, flips, flexion percentiles."""
    from pose3d_dev import read_video, summary

    from imimic_gym.estimators.pose.spatial import Pose3DEstimator

    if not REALDATA.exists():
        return {"skipped": f"{REALDATA} not present"}
    print(f"reading real footage from {REALDATA}", flush=True)
    rows = []
    videos = sorted((REALDATA / "videos").glob("*.mp4")) + sorted(
        p for p in (REALDATA / "dev").glob("*") if p.suffix in (".mp4", ".avi"))
    for path in videos[:2] if quick else videos:
        frames, fps = read_video(str(path), 60 if quick else None)
        for source in ("lift", "world"):
            estimator = Pose3DEstimator(fps=fps, source=source)
            poses = [estimator.update(frame) for frame in frames]
            rows.append({"video": f"{path.parent.name}/{path.name}", "frames": len(frames),
                         "estimator": "pose3d" if source == "lift" else "pose-world",
                         **summary(poses)})
            estimator.model.close()
    return {"rows": rows}


def mimic(quick: bool) -> dict[str, Any]:
    """`imimic mimic` at 1920x1080: the SO-101 from `pose3d` and the planar arm from
    `pose`, frames/s after the first frame, and OpenCV's decode of the same file."""
    from suites.real import decode_seconds_per_frame, make_1080p

    from imimic_gym.clips.video import stream_video
    from imimic_gym.estimators.pose.planar import human_joint_ranges
    from imimic_gym.mimic import run_mimic

    source = REALDATA / "videos" / "ta_chi.mp4"
    if not source.exists():
        return {"skipped": f"{source} not present"}
    work = work_folder("imimic_spatial_")
    path = make_1080p(source, work / "ta_chi_1080p.mp4")
    decode = decode_seconds_per_frame(path)
    result: dict[str, Any] = {"clip": "ta_chi.mp4 at 1920x1080 (H.264, CRF 18)",
                              "decode_frames_per_s": 1.0 / decode}
    runs: dict[str, list[dict[str, Any]]] = {"so101": [], "planar": []}
    for _ in range(1 if quick else MIMIC_REPEATS):  # interleaved: a slow spell hits both
        for name, estimator, robot in (("so101", "pose3d", "so101"),
                                       ("planar", "pose", None)):
            summary = run_mimic(stream_video(path, max_seconds=1.5 if quick else None,
                                             joint_ranges=human_joint_ranges(1)),
                                work / name, estimator=estimator, progress=False, robot=robot)
            runs[name].append({"frames": summary["frames"],
                               "frames_per_s": summary["frames_per_s"],
                               "latency_ms_median": summary["latency_ms_median"]})
            print(f"  1080p mimic {name}: {summary['frames_per_s']:.1f} frames/s", flush=True)
    for name, estimator in (("so101", "pose3d"), ("planar", "pose")):
        rates = [run["frames_per_s"] for run in runs[name]]
        result[name] = {"estimator": estimator, "frames": runs[name][0]["frames"],
                        "frames_per_s": float(np.median(rates)), "runs": rates,
                        "latency_ms_median": float(np.median(
                            [run["latency_ms_median"] for run in runs[name]]))}
    return result


class _LiveCamera:
    """``path`` played about as a camera sends: an MPEG-TS stream on a local TCP port
    (``url``) that starts when the client connects and goes on at the clip's rate
    (ffmpeg, ``-re`` without its initial burst, started on the connection: an ffmpeg
    that listens itself starts its clock before anyone connects and then sends the
    frames "missed" at once, which no camera does). ffmpeg still sends its first half
    second or so at once. ``loops``: times the clip plays again, its timestamps running
    on. ``kill``/``wait`` stop it."""

    def __init__(self, path: Path, loops: int = 0) -> None:
        import socket
        import threading

        self.path, self.loops = path, loops  # loops: times played again after the first
        self.server = socket.socket()
        self.server.bind(("127.0.0.1", 0))
        self.server.listen(1)
        self.url = f"tcp://127.0.0.1:{self.server.getsockname()[1]}"
        self.player: Any = None
        self.stopped = threading.Event()
        self.thread = threading.Thread(target=self._serve, name="live camera", daemon=True)
        self.thread.start()

    def _serve(self) -> None:
        import subprocess

        import imageio_ffmpeg

        try:
            client, _ = self.server.accept()
        except OSError:  # closed before anyone connected
            return
        with client:
            self.player = subprocess.Popen(
                [imageio_ffmpeg.get_ffmpeg_exe(), "-loglevel", "quiet", "-re",
                 "-readrate_initial_burst", "0", "-stream_loop", str(self.loops),
                 "-i", str(self.path), "-c", "copy",
                 "-f", "mpegts", "pipe:1"], stdout=subprocess.PIPE)
            assert self.player.stdout is not None
            while not self.stopped.is_set() and (chunk := self.player.stdout.read1(65536)):
                try:
                    client.sendall(chunk)
                except OSError:  # the reader went away
                    break

    def kill(self) -> None:
        self.stopped.set()
        self.server.close()
        if self.player is not None:
            self.player.kill()

    def wait(self) -> None:
        if self.player is not None:
            self.player.wait()
        self.thread.join(timeout=10.0)


def _mimic_live(path: Path, seconds: float, robot: bool, out: Path) -> dict[str, Any]:
    """`imimic mimic --camera URL` in a process of its own, as a user runs it, on ``path``
    played live (`_LiveCamera`) for ``seconds``; its mimic.json. ``robot``: the SO-101
    (``--robot so101``, pose3d), else the planar arm (pose)."""
    import json
    import math
    import os
    import subprocess
    import sys

    player = _LiveCamera(path, loops=math.ceil(seconds / 10.0))
    try:
        subprocess.run([sys.executable, "-m", "imimic_gym.cli", "mimic", "--camera",
                        player.url, "--max-seconds", f"{seconds:g}", "--out", str(out),
                        *(["--robot", "so101"] if robot else ["--estimator", "pose"])],
                       check=True, capture_output=True, env=dict(os.environ, MUJOCO_GL="egl"))
    finally:
        player.kill()
        player.wait()
    return dict(json.loads((out / "mimic.json").read_text()))


def camera(quick: bool) -> dict[str, Any]:
    """`imimic mimic --camera URL` at 1920x1080 (`_mimic_live`): the SO-101 from `pose3d`
    and the planar arm from `pose`, frames/s (after the first frame) against the
    stream's rate, the frames passed over, and how far each command trailed its frame's
    arrival (mimic.json's ``behind_stream_ms``)."""
    from suites.real import make_1080p

    source = REALDATA / "videos" / "ta_chi.mp4"
    if not source.exists():
        return {"skipped": f"{source} not present"}
    work = work_folder("imimic_camera_")
    path = make_1080p(source, work / "ta_chi_1080p.mp4")
    # The clip looped (40 s in all, timestamps running on), so that the stream
    # outlasts the run and what it passes over, and a run's start-up (the first frames
    # are slower) weighs on its rate as on a short session's, not more.
    seconds = 2.0 if quick else 24.0
    result: dict[str, Any] = {"clip": "ta_chi.mp4 (10 s) at 1920x1080 (H.264, CRF 18), "
                                      "looped, streamed live over local TCP",
                              "seconds": seconds}
    keys = ("frames", "frames_per_s", "latency_ms_median", "frames_passed_over",
            "behind_stream_ms_median", "behind_stream_ms_max")
    runs: dict[str, list[dict[str, Any]]] = {"so101": [], "planar": []}
    for _ in range(1 if quick else MIMIC_REPEATS):
        for name in ("so101", "planar"):
            summary = _mimic_live(path, seconds, name == "so101", work / name)
            runs[name].append({"stream_fps": summary["video_fps"],
                               **{key: summary[key] for key in keys}})
            print(f"  live 1080p mimic {name}: {summary['frames_per_s']:.1f} frames/s of "
                  f"{summary['video_fps']:.2f}, {summary['frames_passed_over']} passed over, "
                  f"behind by {summary['behind_stream_ms_median']:.0f} ms (median)",
                  flush=True)
    for name, estimator in (("so101", "pose3d"), ("planar", "pose")):
        result[name] = {"estimator": estimator, "stream_fps": runs[name][0]["stream_fps"],
                        "runs": [run["frames_per_s"] for run in runs[name]], "all": runs[name],
                        **{key: float(np.median([run[key] for run in runs[name]]))
                           for key in keys}}
    return result


def _camera_table(live: dict[str, Any]) -> str:
    """The camera part's figures, so101 beside planar."""
    so101, planar = live["so101"], live["planar"]
    return table(["", "`--robot so101` (pose3d)", "planar (pose)"], [
        ["frames/s after the first frame", *(f"{run['frames_per_s']:.1f} ({_rates(run)})"
                                             for run in (so101, planar))],
        ["latency, asking for a frame to its command (ms)",
         *(f"{run['latency_ms_median']:.0f}" for run in (so101, planar))],
        ["frames passed over", *(f"{run['frames_passed_over']:.0f}" for run in (so101, planar))],
        ["command behind the frame's arrival, median / max (ms)",
         *(f"{run['behind_stream_ms_median']:.0f} / {run['behind_stream_ms_max']:.0f}"
           for run in (so101, planar))]])


def _rates(run: dict[str, Any]) -> str:
    """The runs' frames/s, in order, "29.9, 27.0, ..."."""
    return ", ".join(f"{rate:.1f}" for rate in run.get("runs", [run["frames_per_s"]]))


def _verdict(rows: list[dict[str, Any]]) -> str:
    """Each target against pose3d's figure over every scenario's clips (the upper end of
    its interval: met only when the whole interval is under the target)."""
    lines = []
    for key, target in TARGETS.items():
        cells = [r[key] for r in rows if r["estimator"] == "pose3d"]
        highs = [c["high"] for c in cells if c.get("high") is not None]
        if not highs:
            continue
        met = max(highs) <= target
        lines.append(f"- `pose3d` {key.replace('_', ' ')} at most {target:g} on every "
                     f"scenario: **{'met' if met else 'missed'}** (highest interval end "
                     f"{max(highs):.1f}).")
    return "\n".join(lines)


def render(data: dict[str, Any]) -> str:
    quick = ("**A quick run (`--quick`): two development clips; not the reported figures.**"
             "\n\n" if data.get("quick") else "")
    out = [f"""## The arm in 3-D (suite `spatial`)

Command: `.venv/bin/python benchmarks/run.py spatial` (JSON:
`benchmarks/results/spatial.json`; this section is rendered from it). {pool_text(data)}
Each clip is one `imimic eval --scenario S --estimator E` cell; per clip, the elbow
flexion's RMSE and the median and 95th percentile of the forearm's and upper arm's
direction errors over its frames with a reading (coverage: the share of frames with one);
`pose3d-depth` reads the depth image beside each RGB frame, as from an RGB-D camera.

{quick}"""]
    rows = data.get("estimators", [])
    if rows:
        out.append(table(
            ["scenario", "estimator", "elbow flexion RMSE (deg)", "forearm direction, median "
             "(deg)", "forearm, 95th pct", "upper arm, median", "coverage", "worst clips "
             "(flexion)"],
            [[f"`{r['scenario']}`", r["estimator"], ci(r["elbow_flexion_rmse_deg"]),
              ci(r["forearm_direction_error_deg"]), ci(r["forearm_direction_p95_deg"]),
              ci(r["upper_arm_direction_error_deg"]), ci(r["coverage"], 2),
              worst(r["elbow_flexion_rmse_deg"])] for r in rows]))
        out.append("Targets (issue 36):\n\n" + _verdict(rows))
        person = [r for r in rows if r["estimator"] == "pose3d"]
        found = min(r["arm_found"]["value"] for r in person)
        elbow = max(r["elbow_2d_rmse_deg"]["value"] for r in person)
        across = max(r["elbow_2d_across_rmse_deg"]["value"] for r in person)
        out.append("""### The rendered person, to the pose model

Under `pose3d` is the pose model's 2-D reading of each frame: the share of frames where it
reads the moving arm (the clip's arm, with trust), and the RMSE of the elbow's angle in the
image on those frames against the rendered truth's pixels, over all of them and over
those where the upper arm and forearm both lie within 45 degrees of the image plane (a
segment pointing at the camera is a few pixels long: its image direction is ill-defined
for any model). The spatial scenarios film a person (face, hair, hands, limbs of human
thickness) against a plain wall.

""" + table(["scenario", "moving arm found", "elbow angle in the image, RMSE (deg)",
             "the same, arm across the view", "worst clips (elbow)"],
            [[f"`{r['scenario']}`", ci(r["arm_found"], 2), ci(r["elbow_2d_rmse_deg"]),
              ci(r["elbow_2d_across_rmse_deg"]), worst(r["elbow_2d_rmse_deg"])]
             for r in person]) + f"""

Targets (issue 36, plain wall): the arm found on at least 95% of frames, **{'met' if found
>= 0.95 else 'missed'}** (lowest scenario mean {found:.2f}); its elbow angle within 6
degrees RMSE, **{'met' if elbow <= 6 else 'missed'}** over all frames (highest scenario
mean {elbow:.1f}), **{'met' if across <= 6 else 'missed'}** with the arm across the view
({across:.1f}).""")
    robot = data.get("robot", [])
    if robot:
        out.append("""### The SO-101 copying the arm

`ImitateVideo3D-v0` on the same clips: the position controller driven by `pose3d`, and by
the truth (the oracle, the control loop's bound), and the learned tracker
(`tracker3d.pt`) driven by the truth; joint RMSE (deg, over the six joints and every
frame) against the truth retargeted onto the robot (`retarget.DirectionRetargeter`).

""" + table(["scenario", "estimator", "controller", "joint RMSE (deg)", "worst clips"],
            [[f"`{r['scenario']}`", r["estimator"], r.get("controller", "position"),
              ci(r["rmse_deg"]), worst(r["rmse_deg"])] for r in robot]))
    real_ = data.get("real", {})
    if real_.get("rows"):
        out.append("""### Real footage (no 3-D truth)

`pose3d` and `pose-world` on every video in ../shared/realdata (`videos/`, evaluation;
`dev/`, development): the share of frames with a reading, the median turn of the forearm
between consecutive frames (deg; lower is steadier), flips (a bone's depth sign changing
between frames while it points well out of the image plane) and the elbow flexion's 5th,
50th and 95th percentiles (deg).

""" + table(["video", "frames", "estimator", "coverage", "forearm turn / frame (deg)",
             "flips", "flexion p5 / p50 / p95 (deg)"],
            [[r["video"], str(r["frames"]), r["estimator"], f"{r['coverage']:.2f}",
              f"{r['smoothness_deg']:.1f}", f"{r['flips']:.0f}",
              f"{r['flexion_p5']:.0f} / {r['flexion_median']:.0f} / {r['flexion_p95']:.0f}"]
             for r in real_["rows"]]))
    hd = data.get("mimic", {})
    if "so101" in hd:
        met = hd["so101"]["frames_per_s"] >= 30
        out.append(f"""### `imimic mimic --robot so101` at 1920x1080

{hd['clip']}, OpenCV decodes {hd['decode_frames_per_s']:.0f} frames/s of it.
`imimic mimic --robot so101` (pose3d, the SO-101 drawn beside the footage, mimic.mp4
written) runs at {hd['so101']['frames_per_s']:.1f} frames/s, the planar `imimic mimic`
(pose) at {hd['planar']['frames_per_s']:.1f} (medians of {len(hd['so101'].get('runs', [0]))}
runs each, interleaved; so101 {_rates(hd['so101'])}, planar {_rates(hd['planar'])};
median latency {hd['so101']['latency_ms_median']:.0f} and
{hd['planar']['latency_ms_median']:.0f} ms).
Keeps up with 30 frames/s: **{'met' if met else 'missed'}**.""")
    live = data.get("camera", {})
    if "so101" in live:
        stream = live["so101"]["stream_fps"]
        kept = live["so101"]["frames_per_s"] >= 0.98 * stream
        out.append(f"""### `imimic mimic --robot so101 --camera` at 1920x1080

{live['clip']}: ffmpeg sends the file at its own {stream:.2f} frames/s (`-re`, not
re-encoded) from when the reader connects, and `imimic mimic --camera
tcp://127.0.0.1:PORT --max-seconds {live['seconds']:g}` reads it, each run a process of its
own as a user starts it. A live source's next frame is read once the frame before has its
command, and the pose model reads it while that frame's picture is drawn and written. The
frames that queued up while the run started (the models loading) are passed over, and so
are frames read over 0.3 s behind the stream's pace later (`FrameStream.keep_live`).
Medians of {len(live['so101']['runs'])} runs each, interleaved:

{_camera_table(live)}

"Behind" is mimic.json's `behind_stream_ms`: a frame's command time less its stream time,
less the run's promptest read (a frame read as it came); unlike the latency it counts a
frame's wait in a queue. ffmpeg still sends its first half second or so at once, ahead
of real time; the stream's clock cannot tell those frames from frames read as they came,
so the start-up reads on while frames come at once (at most 1 s of the stream) and
passes them over too. The pose model's first reading and the robot view's GL context
are made before the catch-up (`run_mimic`'s warm start); the loop's first second is still
slower than the rest, so some runs pass over about ten more frames then.
Keeps up with the 30 frames/s stream (at least 98% of its rate): **{'met' if kept
else 'missed'}**.""")
    return "\n\n".join(out) + "\n"
