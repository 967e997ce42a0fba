"""Pose-seeded DON on a synthetic arm whose keypoints a scripted pose model reports: DON
is seeded on the elbow, carries the forearm between pose frames, and is seeded again
when the elbow moves; nobody in view holds."""

import math
import sys

import cv2
import numpy as np
import pytest

from imimic_gym.estimators.pose.model import KEYPOINTS, BodyKeypoints
from imimic_gym.estimators.pose.seeded_don import CROP, PoseSeededDON

FRAMES = 90
UPPER, FOREARM = 50.0, 45.0  # px


def elbow_at(t: int) -> np.ndarray:
    """The elbow stays, then the person steps right and down at frame 45."""
    return np.array([150.0, 110.0]) if t < 45 else np.array([185.0, 125.0])


def flexion(t: int) -> float:
    """The forearm's angle from the upper arm (rad): 60 +- 40 degrees."""
    return math.radians(60.0 + 40.0 * math.sin(2 * math.pi * t / 30))


def drifting(t: int) -> np.ndarray:
    """An elbow that sways 9 px (0.2 forearm lengths) to the right over the clip."""
    return np.array([150.0 + 0.1 * t, 110.0])


def arm(t: int, elbow_of=elbow_at) -> np.ndarray:
    """Shoulder, elbow, wrist (3, 2) px: the upper arm hangs straight down."""
    elbow = elbow_of(t)
    direction = -math.pi / 2 + flexion(t)
    wrist = elbow + FOREARM * np.array([math.cos(direction), -math.sin(direction)])
    return np.array([elbow - [0.0, UPPER], elbow, wrist])


def frame(t: int, elbow_of=elbow_at) -> np.ndarray:
    picture = np.full((240, 320, 3), 40, np.uint8)
    shoulder, elbow, wrist = (tuple(int(v) for v in np.rint(p)) for p in arm(t, elbow_of))
    cv2.line(picture, shoulder, elbow, (90, 90, 200), 9, cv2.LINE_AA)
    cv2.line(picture, elbow, wrist, (230, 190, 150), 9, cv2.LINE_AA)
    return picture


class ScriptedModel:
    """Reports the true keypoints of the frame it is shown (None: nobody), and counts."""

    def __init__(self, nobody: set[int] = frozenset(), elbow_of=elbow_at) -> None:
        self.nobody, self.t, self.calls, self.elbow_of = nobody, 0, [], elbow_of
        self.times: list[float | None] = []

    def reset(self) -> None:
        self.calls, self.times = [], []

    def __call__(self, picture: np.ndarray, time_s: float | None = None
                 ) -> BodyKeypoints | None:
        t = self.t
        self.calls.append(t)
        self.times.append(time_s)
        if t in self.nobody:
            return None
        points = dict(zip(("left_shoulder", "left_elbow", "left_wrist"),
                          arm(t, self.elbow_of), strict=True))
        points.update({f"right_{j}": np.array([20.0, 20.0 + 10 * k])
                       for k, j in enumerate(("shoulder", "elbow", "wrist", "hand"))})
        points.update(left_hand=points["left_wrist"], left_hip=[150.0, 200.0],
                      right_hip=[120.0, 200.0])
        confidence = np.array([0.1 if name.startswith("right") else 0.95 for name in KEYPOINTS])
        return BodyKeypoints(np.array([points[name] for name in KEYPOINTS], float), confidence)


def run(model: ScriptedModel, **params) -> tuple[PoseSeededDON, list]:
    estimator = PoseSeededDON(fps=30.0, model=model, arm="left", **params)
    estimator.reset()
    out, origins = [], []
    for t in range(FRAMES):
        model.t = t
        out.append(estimator.update(frame(t, model.elbow_of)))
        origins.append(estimator.origin.copy())
    return estimator, out, origins


def test_don_carries_the_forearm_between_pose_frames_and_is_reseeded_when_the_elbow_moves(
        ) -> None:
    model = ScriptedModel()
    estimator, estimates, origins = run(model, pose_every=3)
    truth = np.degrees([flexion(t) for t in range(FRAMES)])
    # The pose model reads every third frame and no other: its cost is bounded.
    assert model.calls == list(range(0, FRAMES, 3))
    # ... and is told each frame's time in the video, so its filters see the real gaps.
    assert model.times == pytest.approx([t / 30.0 for t in model.calls])
    angles = np.degrees([e.angles[0] for e in estimates])
    # Seeded on the elbow: the crop is centred there, REACH forearm lengths a side.
    assert origins[5] == pytest.approx(elbow_at(5) - estimator.side / 2)
    assert estimator.side == pytest.approx(3.2 * FOREARM)
    # The person steps at frame 45: a new crop about the new elbow within a pose frame.
    assert origins[50] == pytest.approx(elbow_at(50) - estimator.side / 2)
    # Between pose frames the angle follows the forearm (after the first, which has
    # neither DON's reading nor a turn rate yet: it holds).
    from_don = sorted(set(range(3, FRAMES)) - set(model.calls))
    error = np.abs(angles - truth)
    # measured 5.7 deg at most, 1.0 on average (issue 40: the mean's bound about 2x)
    assert error[3:].max() < 8.0 and error[from_don].mean() < 2.0
    assert all(e.trust > 0.4 and e.keypoints.shape == (2, 2) for e in estimates)
    # Keypoints drawn in input pixels, at the elbow, and the forearm drawn at the angle
    # given (the upper arm hangs straight down). The elbow measured exactly on the pose
    # model's (0 px): 0.01 px leaves the crop's scaling its float round-off (issue 40).
    for t in from_don:
        elbow, wrist = estimates[t].keypoints
        assert np.hypot(*(elbow - elbow_at(t))) < 0.01
        drawn = math.degrees(math.atan2(-(wrist[1] - elbow[1]), wrist[0] - elbow[0])) + 90.0
        assert drawn == pytest.approx(angles[t], abs=0.01)
    assert CROP == 120


def test_dons_turns_carry_the_forearm_closer_than_the_pose_frames_rate(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """Between pose frames DON's reading turns the estimate; without it (DON never
    reads) the estimate rolls on at the last two pose frames' rate, which misses the
    sinusoid's turns."""
    truth = np.degrees([flexion(t) for t in range(FRAMES)])

    def carried_error() -> float:
        model = ScriptedModel(elbow_of=drifting)
        _, estimates, _ = run(model, pose_every=5)
        between = sorted(set(range(10, FRAMES)) - set(model.calls))
        return float(np.mean([abs(math.degrees(estimates[t].angles[0]) - truth[t])
                              for t in between]))

    with_don = carried_error()
    monkeypatch.setattr(PoseSeededDON, "_don_direction", lambda self, don: None)
    rolled_on = carried_error()
    # measured 0.89 deg with DON, 15.9 rolled on (issue 40: about 2x)
    assert with_don < 1.8 and 3.0 < rolled_on and with_don < 0.12 * rolled_on


def test_a_jump_between_pose_frames_is_taken_as_a_place_not_rolled_on_as_a_speed(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """The forearm holds at 30 degrees, then is at 90 from frame 48: the pose frame at 50
    sees a change far larger than jitter. The estimate takes that reading and holds it;
    rolling it on at 60 degrees per pose interval would overshoot by 12 a frame."""
    monkeypatch.setattr(sys.modules[__name__], "flexion",
                        lambda t: math.radians(30.0 if t < 48 else 90.0))
    monkeypatch.setattr(PoseSeededDON, "_don_direction", lambda self, don: None)
    model = ScriptedModel(elbow_of=drifting)
    _, estimates, _ = run(model, pose_every=5)
    angles = np.degrees([e.angles[0] for e in estimates])
    # The pose frames' readings are taken and held as they are: measured 3e-14 deg off,
    # so the bound is float round-off's (issue 40).
    assert angles[40:48] == pytest.approx(30.0, abs=1e-9)
    assert angles[50:60] == pytest.approx(90.0, abs=1e-9)


def test_a_fast_steady_turn_is_followed_after_two_like_jumps(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """A forearm turning 5 degrees a frame, with no DON: each pose frame is over DISAGREE
    from the carried angle. The first jump is a place (no rate); the second, alike, makes
    it a speed, so the estimate follows the ramp instead of climbing a staircase."""
    monkeypatch.setattr(sys.modules[__name__], "flexion",
                        lambda t: math.radians(20.0 + 5.0 * min(t, 30)))
    monkeypatch.setattr(PoseSeededDON, "_don_direction", lambda self, don: None)
    model = ScriptedModel(elbow_of=drifting)
    _, estimates, _ = run(model, pose_every=5)
    angles = np.degrees([e.angles[0] for e in estimates])
    # measured 9e-14 deg off: the ramp is followed exactly, up to float round-off (issue 40)
    assert angles[10:30] == pytest.approx(20.0 + 5.0 * np.arange(10, 30), abs=1e-9)


def test_the_other_arm_is_read_afresh_and_dons_crop_moves_to_it() -> None:
    """Both arms in view: the left waves, then stops while the right waves. Once the
    right arm is chosen its angle is its own reading (no jump in velocity), and DON's
    crop is about the right elbow."""
    elbows = {"left": np.array([220.0, 110.0]), "right": np.array([90.0, 110.0])}

    def flex(side: str, t: int) -> float:
        waving = (t < 30) == (side == "left")
        return math.radians(60.0 + (40.0 * math.sin(2 * math.pi * t / 20) if waving else 0.0))

    def side_arm(side: str, t: int) -> np.ndarray:
        elbow, direction = elbows[side], -math.pi / 2 + flex(side, t)
        wrist = elbow + FOREARM * np.array([math.cos(direction), -math.sin(direction)])
        return np.array([elbow - [0.0, UPPER], elbow, wrist])

    class TwoArms(ScriptedModel):
        def __call__(self, picture, time_s=None):
            self.calls.append(self.t)
            points = {f"{side}_{joint}": p for side in elbows
                      for joint, p in zip(("shoulder", "elbow", "wrist"),
                                          side_arm(side, self.t), strict=True)}
            points.update({f"{side}_hand": points[f"{side}_wrist"] for side in elbows})
            points.update(left_hip=[200.0, 200.0], right_hip=[110.0, 200.0])
            return BodyKeypoints(np.array([points[name] for name in KEYPOINTS], float),
                                 np.full(len(KEYPOINTS), 0.95))

    model = TwoArms()
    estimator = PoseSeededDON(fps=30.0, model=model, pose_every=5)
    estimator.reset()
    estimates, sides = [], []
    for t in range(FRAMES):
        model.t = t
        picture = np.full((240, 320, 3), 40, np.uint8)
        for side in elbows:
            shoulder, elbow, wrist = (tuple(int(v) for v in np.rint(p))
                                      for p in side_arm(side, t))
            cv2.line(picture, shoulder, elbow, (90, 90, 200), 9, cv2.LINE_AA)
            cv2.line(picture, elbow, wrist, (230, 190, 150), 9, cv2.LINE_AA)
        estimates.append(estimator.update(picture))
        sides.append(estimator.last.side)
    # (A tie at the first frame goes to the right arm; the waving left takes over.)
    assert sides[29] == "left"
    switch = next(t for t in range(30, FRAMES) if sides[t] == "right")
    assert switch < FRAMES - 10 and switch in model.calls
    assert estimates[switch].angles[0] == pytest.approx(flex("right", switch))
    assert estimates[switch].omega[0] == 0.0
    assert estimator.origin + estimator.side / 2 == pytest.approx(elbows["right"])


def test_a_swaying_elbow_moves_dons_pivot_without_a_new_seed() -> None:
    model = ScriptedModel(elbow_of=drifting)
    estimator, estimates, origins = run(model, pose_every=3)
    assert all(np.array_equal(origin, origins[1]) for origin in origins[1:])  # one crop
    from_don = sorted(set(range(1, FRAMES)) - set(model.calls))
    late = [t for t in from_don if t > 60]
    # measured 0.2 px at most (issue 40: about 2x)
    assert late and all(np.hypot(*(estimates[t].keypoints[0] - drifting(t))) < 0.4
                        for t in late)
    # DON's own pivot (crop px) follows the elbow the pose model sees on each pose frame.
    pivot = estimator.don.known_pivot * estimator.side / CROP + estimator.origin
    assert pivot == pytest.approx(drifting(max(model.calls)))
    error = np.degrees([abs(estimates[t].angles[0] - flexion(t)) for t in from_don])
    assert error.mean() < 2.0  # measured 1.0 deg (issue 40: about 2x)


def test_nobody_in_view_holds_and_the_arm_is_found_again() -> None:
    model = ScriptedModel(nobody=set(range(30, 40)))
    _, estimates, _ = run(model, pose_every=3)
    held = [e for t, e in enumerate(estimates) if 30 <= t < 40]
    assert all(e.trust == 0.0 and e.keypoints is None for e in held)
    assert len({float(e.angles[0]) for e in held}) == 1
    assert all(t in model.calls for t in range(31, 40))  # the model asked every frame
    assert estimates[45].trust > 0.4
    # measured 0.33 deg (issue 40: about 2x)
    assert abs(math.degrees(estimates[45].angles[0] - flexion(45))) < 0.7


def test_pose_every_is_checked() -> None:
    with pytest.raises(ValueError, match="pose_every must be a whole number of frames"):
        PoseSeededDON(pose_every=0, model=ScriptedModel())


def test_pose_don_through_the_registry_follows_a_rendered_person_with_the_real_model() -> None:
    """`evaluate_clip` builds "pose-don" from the registry with the real pose model. On the
    default scenario, held-out seed 1000, 60 frames, measured: 7.06 deg RMSE (the pose
    model alone: 9.15); the bound is twice the measured value."""
    from imimic_gym.evaluation import evaluate_clip

    seeded = evaluate_clip("default", "pose-don", seed=1000, frames=60)
    alone = evaluate_clip("default", "pose", seed=1000, frames=60)
    assert seeded["rmse_deg"] < 14.0
    assert abs(seeded["rmse_deg"] - alone["rmse_deg"]) > 0.5  # DON's own readings count
