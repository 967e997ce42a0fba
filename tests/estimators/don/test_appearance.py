"""DON's appearance layer on hand-built frames: a skin-coloured bar on a checkerboard."""

import math

import cv2
import numpy as np
import pytest

from imimic_gym.estimators.don.appearance import LinkAppearance
from imimic_gym.estimators.don.one_link import DON
from imimic_gym.kinematics import wrap_angle

H, W = 120, 160  # the working resolution: the layer takes working frames
PIVOT = np.array([80.0, 75.0])
RADIUS = 40.0
SKIN, PALE, GREY = (235, 190, 150), (240, 244, 250), (170, 180, 200)


def wall() -> np.ndarray:
    """A pale and grey checkerboard of 10 px squares, like the scenarios' back wall."""
    rows, cols = np.indices((H, W)) // 10
    frame = np.empty((H, W, 3), dtype=np.uint8)
    frame[:] = PALE
    frame[(rows + cols) % 2 == 1] = GREY
    return frame


def bar(frame: np.ndarray, angle: float, colour=SKIN, width: int = 3,
        pivot: np.ndarray = PIVOT) -> np.ndarray:
    """``frame`` with a bar drawn from ``pivot`` RADIUS px out at ``angle`` (rad, CCW,
    image up), anti-aliased and smoothed as DON's working frames are."""
    draw_line(frame, pivot, angle, RADIUS, colour, width)
    return cv2.GaussianBlur(frame, (3, 3), 0.7)


def draw_line(frame: np.ndarray, start: np.ndarray, angle: float, length: float, colour,
              width: int) -> None:
    """An anti-aliased line at sub-pixel precision (OpenCV's 4 fractional bits): rounding
    the ends to whole pixels would turn a 40 px bar by up to 0.7 degrees."""
    tip = start + length * np.array([math.cos(angle), -math.sin(angle)])
    cv2.line(frame, tuple(np.rint(16 * start).astype(int)), tuple(np.rint(16 * tip).astype(int)),
             colour, width, cv2.LINE_AA, shift=4)


def error_deg(angle: float | None, truth: float) -> float:
    assert angle is not None
    return abs(math.degrees(float(wrap_angle(angle - truth))))


def test_nothing_is_read_before_a_vouched_reading_teaches_the_colour() -> None:
    """No reading, and one less trusted reading (a proposal, see the next test), teach
    nothing; a vouched reading teaches the colour at once."""
    layer = LinkAppearance()
    frame = bar(wall(), math.radians(40))
    for read, trust in ((False, 1.0), (True, 0.5)):
        assert layer.update(frame, PIVOT, RADIUS, math.radians(40), read, trust) is None
        assert layer.colour is None
    assert layer.update(frame, PIVOT, RADIUS, math.radians(40), True, 0.9) is None
    assert np.allclose(layer.colour[:3], SKIN, atol=25)


def test_two_less_trusted_readings_that_agree_teach_the_colour() -> None:
    """Readings with eta from FIRST_TRUST (below VOUCH_TRUST) propose a first colour: one
    alone, or one of something else (a red bar), teaches nothing; a second of the same
    colour does. Below FIRST_TRUST, or with ``first_trust=None`` (LinkedDON's), they do
    not propose at all."""
    red = (200, 30, 30)
    frames = [(bar(wall(), math.radians(40), colour=red), 40, 0.6),
              (bar(wall(), math.radians(44)), 44, 0.6),
              (bar(wall(), math.radians(48)), 48, 0.4),
              (bar(wall(), math.radians(52)), 52, 0.55)]
    layer, vouched_only = LinkAppearance(), LinkAppearance(first_trust=None)
    learned = []
    for frame, angle, trust in frames:
        for each in (layer, vouched_only):
            assert each.update(frame, PIVOT, RADIUS, math.radians(angle), True, trust) is None
        learned.append(layer.colour)
    assert learned[:3] == [None, None, None]
    assert np.allclose(learned[3][:3], SKIN, atol=25)
    assert vouched_only.colour is None
    # What the colour is for: once DON has lost the link, the layer finds it anywhere.
    assert error_deg(layer.update(bar(wall(), math.radians(80)), PIVOT, RADIUS,
                                  math.radians(52), False, 0.0, lost=True),
                     math.radians(80)) < 0.6


def test_a_ray_across_the_bare_wall_teaches_no_colour() -> None:
    """DON vouching for a wrong direction must not teach the layer the wall's colour."""
    layer = LinkAppearance()
    frame = bar(wall(), math.radians(40))
    assert layer.update(frame, PIVOT, RADIUS, math.radians(100), True, 1.0) is None
    assert layer.colour is None


def short_bar(angle: float, share: float) -> np.ndarray:
    """A bar ``share`` of RADIUS long on the wall: a radius estimate too long, or a link
    half behind a board, so that a vouched ray runs on over the wall past its tip."""
    frame = wall()
    draw_line(frame, PIVOT, angle, share * RADIUS, SKIN, 3)
    return cv2.GaussianBlur(frame, (3, 3), 0.7)


def test_a_colour_found_all_over_the_links_reach_is_not_learned() -> None:
    """A ray running 60% over the wall past the bar's tip picks the wall's grey as the
    bar's colour (so the layer would read the wall); that colour matches a third of the
    square the link can reach, and is not learned. A thick bar, a quarter as wide as it is
    long, is."""
    angle = math.radians(40)
    frame = short_bar(angle, 0.4)
    anything = LinkAppearance(max_share=None)
    anything.update(frame, PIVOT, RADIUS, angle, True, 1.0)
    assert np.allclose(anything.colour[:3], GREY, atol=10)
    layer = LinkAppearance()
    assert layer.update(frame, PIVOT, RADIUS, angle, True, 1.0) is None
    assert layer.colour is None
    thick = wall()
    draw_line(thick, PIVOT, angle, RADIUS, SKIN, round(RADIUS / 4))
    layer.update(cv2.GaussianBlur(thick, (3, 3), 0.7), PIVOT, RADIUS, angle, True, 1.0)
    assert np.allclose(layer.colour[:3], SKIN, atol=25)


@pytest.mark.parametrize("prior_error_deg", [-9.0, -4.0, 0.0, 5.0, 10.0])
def test_the_bar_is_read_to_a_fraction_of_a_degree_from_a_rough_prior(
        prior_error_deg: float) -> None:
    layer = LinkAppearance()
    layer.update(bar(wall(), math.radians(30)), PIVOT, RADIUS, math.radians(30), True, 1.0)
    for truth_deg in (33.0, 47.3, 61.9, 118.4):
        truth = math.radians(truth_deg)
        layer.last = None  # each a view of its own: no track to jump from (see below)
        angle = layer.update(bar(wall(), truth), PIVOT, RADIUS,
                             truth + math.radians(prior_error_deg), True, 1.0)
        assert error_deg(angle, truth) < 0.4  # measured 0.19 deg at most (issue 40: ~2x)


def test_a_pivot_two_pixels_off_does_not_tilt_the_reading() -> None:
    """The direction is a line fitted to the bar, not the ray from the pivot."""
    layer = LinkAppearance()
    wrong = PIVOT + np.array([1.5, -1.5])
    layer.update(bar(wall(), math.radians(30)), wrong, RADIUS, math.radians(30), True, 1.0)
    for truth_deg in (40.0, 75.0, 130.0):
        truth = math.radians(truth_deg)
        layer.last = None  # each a view of its own, as above
        angle = layer.update(bar(wall(), truth), wrong, RADIUS, truth, True, 1.0)
        assert error_deg(angle, truth) < 0.3  # measured 0.13 deg at most (issue 40: ~2x)


def test_where_don_vouches_for_a_direction_nothing_farther_off_is_read() -> None:
    """The link hidden and a bar of its colour 25 degrees from the last reading: on its
    own track the layer takes the bar, but not where DON vouches for the link's old
    direction (a static object of the link's colour is not the link)."""
    truth, other = math.radians(50), math.radians(75)
    readings = {}
    for vouched in (False, True):
        layer = LinkAppearance()
        layer.update(bar(wall(), truth), PIVOT, RADIUS, truth, True, 1.0)
        layer.last = truth  # as if the last frame had read the link
        readings[vouched] = layer.update(bar(wall(), other), PIVOT, RADIUS, truth, vouched,
                                         float(vouched))
    assert error_deg(readings[False], other) < 0.4  # measured 0.19 deg (issue 40: ~2x)
    assert readings[True] is None


def test_a_vouched_jump_away_from_the_layers_track_is_searched_along_the_track() -> None:
    """The layer read the bar at 30 degrees last frame; now the bar is at 32 and DON
    vouches for 75 (a board's edge read as the link). The layer searches its own track
    and reads the bar, where a search about DON's reading would find nothing; a vouched
    reading within 12 degrees of the track is still searched about itself; and where the
    track shows nothing, the layer reads nothing (DON's jump stands)."""
    start, moved, jump = math.radians(30), math.radians(32), math.radians(75)

    def layer_that_read_the_bar() -> LinkAppearance:
        layer = LinkAppearance()
        for _ in range(2):  # learn the colour, then read the bar
            layer.update(bar(wall(), start), PIVOT, RADIUS, start, True, 1.0)
        assert error_deg(layer.last, start) < 0.2  # measured 0.08 deg (issue 40: ~2x)
        return layer

    # measured 0.04 and 0.07 deg below (issue 40: about 2x, and a floor of 0.05)
    layer = layer_that_read_the_bar()
    assert error_deg(layer.update(bar(wall(), moved), PIVOT, RADIUS, jump, True, 1.0),
                     moved) < 0.15
    near = math.radians(40)  # 10 degrees from the track: DON's reading is searched about
    layer = layer_that_read_the_bar()
    assert error_deg(layer.update(bar(wall(), near), PIVOT, RADIUS, near, True, 1.0),
                     near) < 0.2
    layer = layer_that_read_the_bar()
    assert layer.update(bar(wall(), jump), PIVOT, RADIUS, jump, True, 1.0) is None


def test_without_don_the_layer_follows_its_own_track_and_lets_go_of_a_lost_link() -> None:
    """DON holds a stale angle (no reading): the layer follows the bar turning 3 degrees
    a frame from its own readings; once the bar is gone it reads nothing, and it does not
    pick the bar up again until DON vouches for it."""
    layer = LinkAppearance()
    stale = math.radians(30)
    layer.update(bar(wall(), stale), PIVOT, RADIUS, stale, True, 1.0)
    layer.update(bar(wall(), stale), PIVOT, RADIUS, stale, True, 1.0)
    for step in range(1, 15):
        truth = stale + math.radians(3.0 * step)
        angle = layer.update(bar(wall(), truth), PIVOT, RADIUS, stale, False, 0.0)
        assert error_deg(angle, truth) < 0.5  # measured 0.25 deg at most (issue 40: ~2x)
    assert layer.update(wall(), PIVOT, RADIUS, stale, False, 0.0) is None
    back = math.radians(80)
    assert layer.update(bar(wall(), back), PIVOT, RADIUS, stale, False, 0.0) is None
    assert error_deg(layer.update(bar(wall(), back), PIVOT, RADIUS, back, True, 1.0),
                     back) < 0.35  # measured 0.17 deg (issue 40: about 2x)


def test_once_don_has_lost_the_link_the_layer_searches_everywhere_it_can_point() -> None:
    """DON holds a stale 30 degrees and the layer has no track of its own; the bar shows
    at 110 degrees. Only where DON says it has lost the link (hidden) does the layer look
    that far, and still only where the joint can turn."""
    stale, back = math.radians(30), math.radians(110)
    directions = (math.radians(60), math.radians(70))  # -10 to 130 degrees
    readings = {}
    for lost in (False, True):
        layer = LinkAppearance()
        layer.update(bar(wall(), stale), PIVOT, RADIUS, stale, True, 1.0, directions)
        layer.last = None  # as after a frame without a reading
        readings[lost] = layer.update(bar(wall(), back), PIVOT, RADIUS, stale, False, 0.0,
                                      directions, lost=lost)
    assert readings[False] is None
    assert error_deg(readings[True], back) < 0.3  # measured 0.14 deg (issue 40: ~2x)
    narrow = (math.radians(40), math.radians(50))  # -10 to 90 degrees: 110 is out
    layer = LinkAppearance()
    layer.update(bar(wall(), stale), PIVOT, RADIUS, stale, True, 1.0, narrow)
    layer.last = None
    assert layer.update(bar(wall(), back), PIVOT, RADIUS, stale, False, 0.0, narrow,
                        lost=True) is None


def test_a_reading_where_the_joint_cannot_turn_is_none() -> None:
    layer = LinkAppearance()
    inside, outside = math.radians(60), math.radians(-30)
    directions = (math.radians(90), math.radians(100))  # -10 to 190 degrees
    layer.update(bar(wall(), inside), PIVOT, RADIUS, inside, True, 1.0, directions)
    assert layer.update(bar(wall(), outside), PIVOT, RADIUS, outside, True, 1.0,
                        directions) is None


@pytest.mark.parametrize("frame", [np.zeros((H, W, 3), np.uint8),
                                   np.full((H, W, 3), 255, np.uint8)])
def test_blank_frames_read_nothing(frame: np.ndarray) -> None:
    layer = LinkAppearance()
    layer.update(bar(wall(), 1.0), PIVOT, RADIUS, 1.0, True, 1.0)
    assert layer.update(frame, PIVOT, RADIUS, 1.0, True, 1.0) is None


def test_don_with_the_layer_follows_a_slow_link_its_motion_layers_lose() -> None:
    """A skin-coloured bar on the checkerboard, at DON's input size, swings fast (DON
    finds the pivot), then creeps at 0.3 degrees a frame: too little for consecutive
    differences, so the paper's layers hold a stale angle until the slow-link difference
    catches up (measured off by up to 3.0 degrees), while the appearance layer keeps
    reading it (measured within 0.31; the bound is about twice that, issue 40)."""
    pivot = PIVOT * 2
    angles = [math.radians(a) for a in
              [*np.arange(30, 120, 4.0), *np.arange(120, 30, -4.0), *np.arange(30, 45, 0.3)]]
    frames = []
    for angle in angles:
        big = cv2.resize(wall(), (2 * W, 2 * H), interpolation=cv2.INTER_NEAREST)
        draw_line(big, pivot, angle, 2 * RADIUS, SKIN, 6)
        frames.append(big)
    slow = slice(-30, None)
    errors = {}
    for appearance in (False, True):
        estimates = DON(fps=30.0, appearance=appearance,
                        joint_range=(0.0, math.pi)).run(frames)
        errors[appearance] = max(error_deg(e.angles[0], a)
                                 for e, a in zip(estimates[slow], angles[slow], strict=True))
    assert errors[True] < 0.6 and errors[False] > 2.0


def test_a_colour_learned_from_something_else_is_learned_again() -> None:
    """A colour taught by something else (a red ball) reads nothing where DON vouches for
    the link; after a few such frames the layer learns the link's colour."""
    layer = LinkAppearance()
    layer.colour = (200.0, 30.0, 30.0, 0.0)
    readings = [layer.update(bar(wall(), math.radians(a)), PIVOT, RADIUS, math.radians(a),
                             True, 1.0) for a in range(40, 60, 2)]
    assert np.allclose(layer.colour[:3], SKIN, atol=25)
    assert error_deg(readings[-1], math.radians(58)) < 0.6


@pytest.mark.parametrize("disagree", [None, math.inf])
def test_vouched_readings_ten_degrees_off_relearn_the_colour_only_by_default(
        disagree: float | None) -> None:
    """The colour taught by a right reading, then vouched readings 10 degrees off the
    bar (a fit about a pivot a few pixels off): by default, RELEARN such frames drop the
    colour and the layer loses the bar; with ``disagree=math.inf`` (LinkedDON's) it keeps
    reading it."""
    layer = LinkAppearance() if disagree is None else LinkAppearance(disagree_deg=disagree)
    angles = range(40, 70, 2)
    readings = [layer.update(bar(wall(), math.radians(a)), PIVOT, RADIUS,
                             math.radians(a + (10 if k else 0)), True, 1.0)
                for k, a in enumerate(angles)]
    assert readings[0] is None  # the frame that teaches the colour
    later = list(zip(readings[1:], angles[1:], strict=True))
    if disagree is None:
        assert any(r is None for r, _ in later)
    else:
        # measured 0.30 deg at most (issue 40: about 2x)
        assert max(error_deg(r, math.radians(a)) for r, a in later) < 0.6


def test_every_setting_of_the_layer_comes_from_its_config() -> None:
    """DON and LinkedDON hand their `colour` settings to the layer; a field given to the
    layer replaces the config's."""
    from imimic_gym.estimators.don.config import AppearanceConfig, don_preset, override
    from imimic_gym.estimators.don.one_link import DON

    don = DON(config=override(don_preset("rgb"), {"colour.sigma": 20.0, "colour.near": 3}))
    assert don.appearance is not None
    assert don.appearance.config.sigma == 20.0 and don.appearance.config.near == 3
    assert not np.array_equal(don.appearance.table, LinkAppearance().table)
    assert LinkAppearance(AppearanceConfig(step_deg=3.0)).turns == 120
    layer = LinkAppearance(AppearanceConfig(max_share=0.5), max_share=None)
    assert layer.max_share is None and layer.disagree == math.radians(6.0)
