"""DON's layers on hand-built frame sequences with known answers, and the never-NaN cases."""

import math
import warnings

import cv2
import numpy as np
import pytest

from imimic_gym.estimators.don.config import DONConfig
from imimic_gym.estimators.don.motion_mask import SlidingExtrema
from imimic_gym.estimators.don.one_link import DON, FrameShapeError
from imimic_gym.estimators.don.regions import component_lines
from imimic_gym.kinematics import wrap_angle

H, W, FPS = 240, 320, 30.0
PIVOT = np.array([160.0, 150.0])
# The tests of eta's value smooth the bar as DON did before its default dropped the
# Gaussian: the bar's hard, aliased edges make the visible length it measures scatter by
# about 3% without one (eta 0.94-0.99 in the clear, and a few frames of a link 15% seen
# read 0.4 before it counts as hidden), and these tests check eta's arithmetic against a
# known visible fraction, not aliasing. Rendered clips and cameras have soft edges.
SMOOTH_BAR = 7


def bar_frame(angle: float, length: float = 100.0, occluder: tuple | None = None) -> np.ndarray:
    """A white bar on black turned to ``angle`` (rad, CCW, image up) about PIVOT; an
    optional black rectangle (x0, y0, x1, y1) drawn over it."""
    frame = np.zeros((H, W, 3), dtype=np.uint8)
    tip = PIVOT + length * np.array([math.cos(angle), -math.sin(angle)])
    cv2.line(frame, tuple(PIVOT.astype(int)), tuple(np.rint(tip).astype(int)),
             (255, 255, 255), thickness=8)
    if occluder is not None:
        x0, y0, x1, y1 = occluder
        frame[y0:y1, x0:x1] = 0
    return frame


def sweep(rate_deg_per_frame: float, frames: int, start_deg: float = 20.0) -> list[float]:
    """Back-and-forth between 20 and 160 degrees at a constant rate."""
    angles, angle, step = [], start_deg, rate_deg_per_frame
    for _ in range(frames):
        angles.append(math.radians(angle))
        if not 20 <= angle + step <= 160:
            step = -step
        angle += step
    return angles


def test_a_bar_turning_at_a_known_rate_gives_that_angle_and_omega() -> None:
    rate = 3.0  # degrees per frame = 90 deg/s at 30 fps
    angles = sweep(rate, 80)
    don = DON(fps=FPS)
    estimates = don.run(bar_frame(a) for a in angles)
    steady = [
        (e, a) for i, (e, a) in enumerate(zip(estimates, angles, strict=True))
        if i > 30 and abs(math.degrees(a) - 90) < 50  # clear of the turning points
    ]
    errors = [abs(math.degrees(e.angles[0] - a)) for e, a in steady]
    assert max(errors) < 1.1 and np.mean(errors) < 0.3  # measured 0.54, 0.15 (issue 40: ~2x)
    omegas = [abs(math.degrees(e.omega[0])) for e, _ in steady]
    # measured 0.29% off (issue 40: about 2x)
    assert np.median(omegas) == pytest.approx(rate * FPS, rel=0.006)
    pivot = don.link.pivot() * don.scale
    assert np.hypot(*(pivot - PIVOT)) < 1.4  # px; measured 0.68 (issue 40: about 2x)


def test_a_known_pivot_is_used_from_the_first_moving_frame() -> None:
    angles = sweep(3.0, 20, start_deg=60)
    don = DON(fps=FPS, pivot=tuple(PIVOT))
    estimates = don.run(bar_frame(a) for a in angles)
    # measured 0.13 deg (issue 40: about 2x, and a floor of 0.05)
    assert abs(math.degrees(estimates[5].angles[0] - angles[5])) < 0.3


def before_the_pivot(don: DON, frames: list[np.ndarray]) -> list:
    """DON's estimates for ``frames`` up to the frame its pivot is agreed."""
    don.reset()
    estimates = []
    for frame in frames:
        estimates.append(don.update(frame))
        if don.link.pivot() is not None:
            return estimates[:-1]
    return estimates


def test_omega_does_not_wait_for_the_pivot() -> None:
    # Until the pivot of a bar turning 3 degrees a frame is agreed, the guesses' own
    # path gives omega (it stayed 0 while they were not fed to it).
    estimates = before_the_pivot(DON(fps=FPS, joint_range=(0.0, math.pi)),
                                 [bar_frame(a) for a in sweep(3.0, 20)])
    assert len(estimates) >= 10
    assert estimates[0].trust == 0.0  # the placeholder, before anything moved
    omegas = [math.degrees(e.omega[0]) for e in estimates[3:]]
    assert np.median(omegas) == pytest.approx(3.0 * FPS, rel=0.055)  # measured 2.7% off


def test_eta_sees_an_occluder_before_the_pivot_is_agreed() -> None:
    # From frame 6 only the inner 55 px of the 100 px bar are visible; until the pivot
    # is agreed, eta comes from the guessed regions' sizes.
    frames = [bar_frame(a) for a in sweep(3.0, 20)]
    outside = np.ones((H, W), dtype=np.uint8)
    cv2.circle(outside, tuple(PIVOT.astype(int)), 55, 0, -1)
    for frame in frames[6:]:
        frame[outside == 1] = 0
    trust = [e.trust for e in before_the_pivot(
        DON(fps=FPS, joint_range=(0.0, math.pi), gaussian=SMOOTH_BAR), frames)]
    assert len(trust) >= 12
    assert min(trust[1:6]) > 0.9
    assert 0.45 < min(trust[8:]) and max(trust[8:]) < 0.7


def test_reference_direction_is_subtracted() -> None:
    angles = sweep(3.0, 40, start_deg=60)
    plain = DON(fps=FPS, pivot=tuple(PIVOT)).run(bar_frame(a) for a in angles)
    shifted = DON(fps=FPS, pivot=tuple(PIVOT), reference_direction=math.pi / 2).run(
        bar_frame(a) for a in angles)
    assert math.degrees(plain[-1].angles[0] - shifted[-1].angles[0]) == pytest.approx(90.0)


def test_still_black_and_short_inputs_give_defined_estimates() -> None:
    black = np.zeros((H, W, 3), dtype=np.uint8)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for frames in ([black] * 15, [black] * 3, [bar_frame(1.0)] * 12, [black]):
            for estimate in DON(fps=FPS).run(frames):
                values = np.concatenate([estimate.angles, estimate.omega, estimate.alpha,
                                         estimate.torque, [estimate.trust]])
                assert np.all(np.isfinite(values))
                # Nothing ever moved: no reading, so trust 0 (a placeholder angle).
                assert estimate.trust == 0.0 and not estimate.predicted


@pytest.mark.parametrize(("visible", "low", "high"),
                         [(0.8, 0.72, 0.85), (0.5, 0.42, 0.55), (0.3, 0.22, 0.35),
                          (0.15, 0.0, 0.2)])
def test_an_occluder_hiding_the_outer_part_of_the_link_gives_its_eta(
        visible: float, low: float, high: float) -> None:
    """From frame 40 on, everything farther than ``visible`` link lengths from the pivot is
    hidden. eta reads the fraction still seen, within a few hundredths; with too little
    left to measure, the link counts as hidden."""
    angles = [math.radians(30 + 2.0 * i) for i in range(50)]
    seen = np.zeros((H, W), dtype=np.uint8)
    cv2.circle(seen, tuple(PIVOT.astype(int)), int(visible * 100), 255, -1)
    frames = [bar_frame(a) for a in angles]
    for frame in frames[40:]:
        frame[seen == 0] = 0
    trust = [e.trust for e in DON(fps=FPS, gaussian=SMOOTH_BAR).run(frames)]
    assert min(trust[30:41]) > 0.95  # the whole link, turning steadily
    # Frame 40 hides the link, the difference to frame 41 still sees it vanish, and a link
    # missing for one frame is not yet hidden (`DON._link_missing`).
    assert low <= min(trust[43:49]) and max(trust[43:49]) <= high


@pytest.mark.parametrize("distractor", [False, True])
def test_a_link_hidden_for_longer_than_the_window_stays_distrusted(distractor: bool) -> None:
    """The turning bar disappears behind a static black board at frame 40 and stays there
    for 30 frames (three windows), with nothing else moving or with a dot moving in a
    corner. From the second frame without it, eta stays 0 until the link is seen again;
    it does not drift back to 1 once the last measurement has left the window."""
    angles = [math.radians(30 + 2.0 * i) for i in range(70)]
    frames = [bar_frame(a) for a in angles]
    for i, frame in enumerate(frames[40:]):
        frame[:] = 0
        if distractor:
            cv2.circle(frame, (20 + 2 * i, 20), 4, (255, 255, 255), -1)
    trust = [e.trust for e in DON(fps=FPS).run(frames)]
    assert min(trust[30:40]) > 0.85
    assert max(trust[42:]) < 0.05


def test_a_region_where_the_joint_cannot_turn_is_not_the_link() -> None:
    """A second bar turns the other way on the far side of the pivot, along a ray through
    it: without a joint range it can pass for the link (a flipped reading), with the range
    it cannot."""
    angles = sweep(3.0, 60, start_deg=40)
    frames = []
    for angle in angles:
        frame = bar_frame(angle)
        away = np.array([math.cos(-angle - 0.3), math.sin(angle + 0.3)])
        cv2.line(frame, tuple(np.rint(PIVOT + 20 * away).astype(int)),
                 tuple(np.rint(PIVOT + 110 * away).astype(int)), (255, 255, 255), 12)
        frames.append(frame)
    estimates = DON(fps=FPS, joint_range=(0.0, math.pi)).run(frames)
    errors = [abs(math.degrees(e.angles[0] - a)) for e, a in zip(estimates, angles, strict=True)]
    # measured 1.25 and 1.98 deg (issue 40: about 2x, the second left at 1.5x)
    assert max(errors[10:30]) < 2.5 and max(errors[-10:]) < 3.0


def test_no_reported_angle_passes_the_joints_limits() -> None:
    """A bar swings between 20 and 160 degrees, then down to 5; DON is told the joint
    turns between 30 and 150 (a range narrower than the motion, as a user's guess of it
    may be). It reads the bar past both limits (the pointing range has a margin), but
    reports the limit there: nothing under 30 or over 150, and 30 at the end."""
    angles = [*sweep(4.0, 40), *(math.radians(a) for a in range(20, 4, -3)), math.radians(5)]
    frames = [bar_frame(a) for a in angles]
    limits = (math.radians(30), math.radians(150))
    estimates = DON(fps=FPS, joint_range=limits).run(frames)
    reported = np.degrees([e.angles[0] for e in estimates])
    assert reported.min() >= 30.0 - 1e-9 and reported.max() <= 150.0 + 1e-9
    assert reported[-1] == pytest.approx(30.0)
    # inside the range: as read (measured 0.15 deg; issue 40: about 2x)
    assert abs(reported[25] - math.degrees(angles[25])) < 0.3


def test_motion_stopping_holds_the_last_angle() -> None:
    angles = sweep(3.0, 40, start_deg=40)
    frames = [bar_frame(a) for a in angles] + [bar_frame(angles[-1])] * 10
    estimates = DON(fps=FPS).run(frames)
    # measured 0.008 deg apart (issue 40: a floor of 0.05 on a held angle)
    assert math.degrees(estimates[-1].angles[0]) == pytest.approx(
        math.degrees(estimates[-10].angles[0]), abs=0.05)
    assert estimates[-1].omega[0] == 0.0


@pytest.mark.parametrize(
    ("frame", "message"),
    [(np.zeros((H, W), dtype=np.uint8), r"\(H, W, 3\) uint8 RGB frames, got \(240, 320\)"),
     (np.zeros((H, W, 3), dtype=np.float32), r"got \(240, 320, 3\) float32"),
     ("not a frame", "got str")],
)
def test_wrong_frames_are_named(frame, message: str) -> None:
    with pytest.raises(FrameShapeError, match=message):
        DON().update(frame)


def test_a_frame_of_another_size_mid_clip_is_refused() -> None:
    don = DON()
    don.update(np.zeros((H, W, 3), dtype=np.uint8))
    with pytest.raises(FrameShapeError, match=r"frame is \(120, 160, 3\), but this clip's "
                                               r"frames are \(240, 320, 3\)"):
        don.update(np.zeros((120, 160, 3), dtype=np.uint8))


def test_sliding_extrema_equal_brute_force() -> None:
    rng = np.random.default_rng(0)
    images = [rng.integers(0, 256, (6, 7, 3), dtype=np.uint8) for _ in range(37)]
    window = SlidingExtrema(5)
    for t, image in enumerate(images):
        window.push(image)
        recent = np.stack(images[max(0, t - 4): t + 1])
        low, high = window.extrema()
        assert np.array_equal(low, recent.min(axis=0)) and np.array_equal(high, recent.max(axis=0))
        box = (slice(1, 5), slice(2, 7))
        low, high = window.extrema(box)
        assert np.array_equal(low, recent.min(axis=0)[box])
        assert np.array_equal(high, recent.max(axis=0)[box])


def test_component_lines_find_a_drawn_line() -> None:
    mask = np.zeros((100, 100), dtype=bool)
    cv2.line(mask.view(np.uint8), (10, 80), (70, 20), 1, thickness=3)
    (line,) = component_lines(mask, min_area=5)
    direction = line[2:4] * np.sign(line[2])
    assert np.allclose(direction, [math.sqrt(0.5), -math.sqrt(0.5)], atol=0.02)
    assert line[5] > 5  # elongated


def test_a_sweeping_board_does_not_drag_a_found_pivot() -> None:
    """After 40 frames of the bar alone, a bright board sweeps across the scene: its
    long moving edges are lines too, but only regions accepted as the link refine the
    pivot, so it stays put and the angle stays right where the bar is visible."""
    angles = sweep(3.0, 100)
    frames = []
    for i, angle in enumerate(angles):
        frame = bar_frame(angle)
        if i >= 40:
            x = int(20 + (i - 40) * 4) % 300
            frame[20:220, x:x + 30] = (200, 170, 90)
        frames.append(frame)
    don = DON(fps=FPS)
    for i, frame in enumerate(frames):
        don.update(frame)
        if i == 39:
            found = don.link.pivot() * don.scale
    # px; measured 0.81 and 2.86 (issue 40: about 2x, the second left at its 3 px)
    assert np.hypot(*(found - PIVOT)) < 1.6
    assert np.hypot(*(don.link.pivot() * don.scale - PIVOT)) < 3.0



def test_an_edge_sweeping_across_the_joint_is_not_the_link() -> None:
    """The bar turns, then rests at its last angle while a tall board sweeps across the
    scene. Its vertical edges pass through the pivot and point along the joint's range,
    but they reach far back past the pivot, which a link never does: the estimate stays
    on the resting bar."""
    angles = sweep(3.0, 30, start_deg=40)
    rest = angles[-1]
    frames = [bar_frame(angle) for angle in angles]
    for x in range(20, 290, 4):
        frame = bar_frame(rest)
        frame[20:230, x:x + 24] = (200, 170, 90)
        frames.append(frame)
    estimates = DON(fps=FPS, pivot=tuple(PIVOT), joint_range=(0.0, math.pi)).run(frames)
    errors = [abs(math.degrees(e.angles[0] - rest)) for e in estimates[30:]]
    assert max(errors) < 1.6  # measured 0.79 deg (issue 40: about 2x)


def test_a_radius_measured_on_a_short_first_movement_does_not_lock_the_link_out() -> None:
    """The first thing that turns is short (a 24 px stub, so r ~ 24); then the full
    100 px bar turns. The radius gate (1.6 r) would refuse the bar's regions forever;
    it is dropped after 5 frames without a match, and the bar is followed."""
    stub, bar = sweep(3.0, 15, start_deg=40), sweep(3.0, 60, start_deg=100)
    frames = [bar_frame(a, length=24.0) for a in stub] + [bar_frame(a) for a in bar]
    estimates = DON(fps=FPS, pivot=tuple(PIVOT), joint_range=(0.0, math.pi)).run(frames)
    errors = [abs(math.degrees(e.angles[0] - a))
              for e, a in zip(estimates[-30:], bar[-30:], strict=True)]
    assert max(errors) < 1.4  # measured 0.69 deg (issue 40: about 2x)


def test_a_board_crossing_the_first_movement_does_not_fix_a_wrong_pivot() -> None:
    """exp3-forearm-low, seed 100: the board sweeps past while the forearm makes its first
    movement. A first pivot is taken only when two solves agree, so the board's edges
    (which move) do not set it, and DON follows the forearm."""
    from imimic_gym.clips import load_clip
    from imimic_gym.clips.scenarios import get_scenario
    from imimic_gym.metrics import angle_rmse_deg

    spec = get_scenario("exp3-forearm-low", seed=100)
    clip = load_clip(spec, progress=False)
    don = DON(fps=clip.fps, reference_direction=spec.reference_direction,
              joint_range=spec.joint_ranges[0])
    angles = np.array([e.angles for e in don.run(clip.frames)])
    # measured 2.1 deg on seed 100 (issue 40: about 2x)
    assert angle_rmse_deg(angles[15:], clip.truth.angles[15:]) < 4.5


@pytest.mark.parametrize("search_when_lost", [False, True])
def test_a_forearm_back_in_view_after_the_board_is_read_while_it_rests(
        search_when_lost: bool) -> None:
    """exp3-forearm-high, development seed 3: the forearm vanishes behind the board while
    turning (DON: hidden) and comes out at frame 88, nearly at rest. Without
    ``search_when_lost`` DON holds the angle it vanished at, 16.6 degrees off at frame
    88; with it (the default) the appearance layer looks for its colour everywhere the
    elbow can turn and reads it (measured within 1.3 degrees over frames 88-100; the
    bound is about twice that, issue 40)."""
    from imimic_gym.clips import load_clip
    from imimic_gym.clips.scenarios import get_scenario

    spec = get_scenario("exp3-forearm-high", seed=3)
    clip = load_clip(spec, progress=False)
    don = DON(fps=clip.fps, reference_direction=spec.reference_direction,
              joint_range=spec.joint_ranges[0], search_when_lost=search_when_lost)
    angles = np.array([e.angles[0] for e in don.run(clip.frames)])
    error = np.abs(np.degrees(wrap_angle(angles[88:101] - clip.truth.angles[88:101, 0])))
    if search_when_lost:
        assert error.max() < 2.7
    else:
        assert error.max() > 10.0  # measured 13.3


def test_a_forearm_swinging_past_the_boards_edge_is_read_through_the_merge() -> None:
    """exp3-forearm-high, development seed 13: from frame 122 the forearm, in full view,
    turns 4 degrees a frame toward the board's sliding edge, and their moving pixels
    merge into one region along no ray from the elbow. DON held 33.5 degrees through it
    (frames 122-128, up to 24 degrees off, then hidden for 30 frames); it now erases the
    edge where it should be and reads the forearm (measured within 1.25 degrees; the
    bound is about twice that, issue 40)."""
    from imimic_gym.clips import load_clip
    from imimic_gym.clips.scenarios import get_scenario

    spec = get_scenario("exp3-forearm-high", seed=13)
    clip = load_clip(spec, progress=False)
    don = DON(fps=clip.fps, reference_direction=spec.reference_direction,
              joint_range=spec.joint_ranges[0])
    angles = np.array([e.angles[0] for e in don.run(clip.frames)])
    error = np.abs(np.degrees(wrap_angle(angles[122:129] - clip.truth.angles[122:129, 0])))
    assert error.max() < 2.5


def test_a_link_found_again_far_away_is_no_velocity() -> None:
    """The bar turns 3 degrees a frame, vanishes for 5 frames and reappears 90 degrees
    on: once the 45-degree gate has lapsed (5 frames without the link), DON reads the new
    angle, and no arm's speed (no 2700 deg/s) from the jump."""
    angles = sweep(3.0, 40, start_deg=40)
    frames = [bar_frame(a) for a in angles]
    frames += [np.zeros((H, W, 3), dtype=np.uint8)] * 5
    later = [angles[-1] + math.radians(90 + 3 * k) for k in range(1, 10)]
    frames += [bar_frame(a) for a in later]
    estimates = DON(fps=FPS, pivot=tuple(PIVOT)).run(frames)
    back = estimates[-3]
    # measured 0.44 deg and 86 deg/s (the bar's own 90) (issue 40: about 2x)
    assert abs(math.degrees(wrap_angle(back.angles[0] - later[-3]))) < 0.9
    assert abs(math.degrees(back.omega[0])) < 180.0


def test_a_link_turning_too_slowly_for_consecutive_differences_is_still_followed() -> None:
    """A dim bar (30 grey levels) turns 3 degrees a frame, then 0.3: too little for two
    consecutive frames to differ by the threshold, so l_1 shows nothing along it. The
    difference over half and all of the window still finds it, and DON follows it to
    within 3 degrees instead of holding (which leaves it 15 degrees behind)."""
    angles = [math.radians(30 + 3.0 * i) for i in range(20)]
    angles += [math.radians(87 + 0.3 * i) for i in range(1, 60)]
    frames = []
    for angle in angles:
        frame = np.zeros((H, W, 3), dtype=np.uint8)
        tip = PIVOT + 100.0 * np.array([math.cos(angle), -math.sin(angle)])
        cv2.line(frame, tuple(PIVOT.astype(int)), tuple(np.rint(tip).astype(int)),
                 (30, 30, 30), thickness=8)
        frames.append(frame)
    estimates = DON(fps=FPS, pivot=tuple(PIVOT)).run(frames)
    errors = [abs(math.degrees(e.angles[0] - a)) for e, a in zip(estimates, angles,
                                                                  strict=True)]
    assert max(errors[40:]) < 0.65  # measured 0.32 deg (issue 40: about 2x)


@pytest.mark.parametrize("wall", [(200, 200, 210), (120, 120, 120)])
def test_a_thin_link_of_low_contrast_is_followed_without_a_gaussian(wall: tuple) -> None:
    """A 2 px bar, skin against a pale wall (or 30 grey levels above a grey one), turns a
    degree a frame. Its difference pixels are few and faint; a Gaussian spreads them
    under the threshold and DON's reading lags and jumps (9 degrees off at worst with
    the 7x7 kernel DON used before); the default, without one, stays within a degree."""
    skin = (230, 190, 160) if wall[0] == 200 else (150, 150, 150)
    angles = [math.radians(20 + 1.0 * i) for i in range(100)]
    frames = []
    for angle in angles:
        frame = np.full((H, W, 3), wall, dtype=np.uint8)
        tip = PIVOT + 100.0 * np.array([math.cos(angle), -math.sin(angle)])
        cv2.line(frame, tuple(PIVOT.astype(int)), tuple(np.rint(tip).astype(int)), skin,
                 thickness=2, lineType=cv2.LINE_AA)
        frames.append(frame)
    estimates = DON(fps=FPS, pivot=tuple(PIVOT)).run(frames)
    errors = [abs(math.degrees(wrap_angle(e.angles[0] - a)))
              for e, a in zip(estimates[20:], angles[20:], strict=True)]
    assert max(errors) < 0.8  # measured 0.38 and 0.37 deg (issue 40: about 2x)


def test_one_frame_without_the_link_does_not_read_as_occlusion() -> None:
    """A duplicated frame in a steady turn (a video that repeats a frame) leaves one
    frame with no moving pixel. That is a failed reading, not an occluder: eta stays
    high over the next window instead of dropping to 0 for ten frames."""
    angles = [math.radians(30 + 3.0 * i) for i in range(30)]
    angles[8] = angles[7]  # before the window fills: no longer difference to read it from
    estimates = DON(fps=FPS, pivot=tuple(PIVOT)).run(bar_frame(a) for a in angles)
    trust = [e.trust for e in estimates]
    assert min(trust[9:19]) > 0.85


def test_the_prediction_layer_carries_a_hidden_link_on() -> None:
    """The bar turns 3 degrees a frame and is hidden (black) for frames 40-45. With the
    prediction layer on, those estimates are flagged predicted and roll on in the
    direction of the turn, nearer the truth than the held angle without it; both stay
    finite, and the link is read again once it reappears."""
    angles = [math.radians(30 + 3.0 * i) for i in range(56)]
    frames = [bar_frame(a) for a in angles]
    for frame in frames[40:46]:
        frame[:] = 0
    on = DON(fps=FPS, pivot=tuple(PIVOT), trust_threshold=0.3).run(frames)
    off = DON(fps=FPS, pivot=tuple(PIVOT)).run(frames)

    def error(estimates: list, frame: int) -> float:
        return abs(math.degrees(wrap_angle(estimates[frame].angles[0] - angles[frame])))

    hidden = range(41, 46)
    assert all(on[i].predicted for i in hidden) and not any(off[i].predicted for i in hidden)
    assert np.mean([error(on, i) for i in hidden]) < np.mean([error(off, i) for i in hidden]) - 3
    assert all(np.isfinite(e.angles).all() and np.isfinite(e.omega).all() for e in on)
    # measured 0.11 deg (issue 40: about 2x, and a floor of 0.05)
    assert error(on, 55) < 0.25 and not on[55].predicted


def test_the_prediction_layer_does_not_roll_on_from_a_reading_of_half_the_link() -> None:
    """As above, but for the five frames before it vanishes the bar shows only its inner
    half: DON reads it, last as it vanishes in frame 40, with eta near 0.5, under
    ``predict_from_trust``. That velocity is not trusted, so once the bar is gone the
    estimate holds, not predicted; with the whole bar seen up to the last frame (the test
    above) the same frames are predicted."""
    angles = [math.radians(30 + 3.0 * i) for i in range(56)]
    frames = [bar_frame(a, length=50.0 if 35 <= i < 40 else 100.0)
              for i, a in enumerate(angles)]
    for frame in frames[40:46]:
        frame[:] = 0
    estimates = DON(fps=FPS, pivot=tuple(PIVOT), trust_threshold=0.3).run(frames)
    assert 0.3 < estimates[40].trust < DONConfig().predict_from_trust  # the last frame it is read
    assert not any(estimates[i].predicted for i in range(41, 46))
    held = estimates[41].angles[0]
    assert all(estimates[i].angles[0] == held for i in range(42, 46))


@pytest.mark.parametrize("fps", [0.0, -30.0, float("nan"), float("inf")])
def test_a_frame_rate_that_is_not_positive_and_finite_is_refused(fps) -> None:
    from imimic_gym.estimators.don.linked import LinkedDON

    message = "fps must be a positive, finite number of frames per second"
    with pytest.raises(ValueError, match=message):
        DON(fps=fps)
    with pytest.raises(ValueError, match=message):
        LinkedDON((-1, 0), ((-1.0, 1.0), (-1.0, 1.0)), fps=fps)


def test_an_empty_frame_is_a_frame_shape_error() -> None:
    from imimic_gym.estimators import FrameShapeError

    with pytest.raises(FrameShapeError, match=r"got \(0, 0, 3\) uint8"):
        DON().update(np.zeros((0, 0, 3), np.uint8))
