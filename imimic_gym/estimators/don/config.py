"""Typed configuration of DON (`DONConfig`) and LinkedDON (`LinkedDONConfig`): every tuning
knob in one frozen dataclass, with a preset per modality (`don_preset`,
`linked_don_preset`). Why each default is what it is: `docs/decisions/` (each field names
its record).

Units: pixels are working-resolution pixels (the frame area-averaged to
``working_height`` rows), angles in degrees where a field ends in ``_deg``, grey levels
for thresholds, frames for counts of frames. ``gaussian`` is a kernel size at 240 rows (0:
none beyond the area average). `override` applies ``NAME=VALUE`` settings, nested ones as
``tracker.NAME`` or ``colour.NAME``, as the development-seed tools pass them.
"""

from __future__ import annotations

import ast
import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, TypeVar

__all__ = ["AppearanceConfig", "DONConfig", "LinkedDONConfig", "TrackerConfig",
           "don_preset", "linked_don_preset", "override", "parse_setting"]


@dataclass(frozen=True)
class TrackerConfig:
    """`LinkTracker`: object regression about one pivot (`docs/decisions/don-pivot.md`,
    `don-occluder-edges.md`, `don-joint-limits.md`)."""

    shift_px: float = 1.5  # an edge sliding this far sideways in a frame ...
    turn_deg: float = 2.0  # ... while turning less than this is translating, not turning
    rigid_frames: int = 6  # an edge parallel to itself this many frames running is rigid
    reseek_px: float = 6.0  # a second pivot estimate this far off is weighed against the first
    reseek_gain: float = 1.5  # it replaces the first where the lines fan out this much wider
    reseek_bins: int = 5  # ... over at least this many bearing bins
    bearing_bin_deg: float = 4.0  # bearing bin of that fan
    reseek_memory: int = 80  # recent lines the two pivots are scored on
    range_margin_deg: float = 20.0  # how far past its joint range a region may be the link
    edge_memory: int = 6  # frames a sliding edge is carried on while out of sight
    erase_px: int = 3  # width of the line an expected edge is erased with
    parallel_deg: float = 10.0  # a region this near parallel to an erased edge is its remnant
    guess_edge_px: float = 8.0  # before the pivot: a region this near an edge's axis ...
    guess_edge_deg: float = 20.0  # ... and this near parallel to it is that edge
    guess_edge_length: float = 12.0  # only edges longer than this (std along the axis) count
    guess_min_length: float = 4.0  # the shortest region (std along its axis) to guess from


@dataclass(frozen=True)
class AppearanceConfig:
    """`LinkAppearance`: the link's direction from its colour
    (`docs/decisions/don-appearance.md`). ``None`` for ``max_share`` or ``first_trust``
    turns that rule off; ``disagree_deg`` ``math.inf`` counts only frames without a
    reading against the colour."""

    step_deg: float = 2.0  # spacing of the search's ray directions
    vouch_trust: float = 0.8  # DON's eta from which its reading vouches for the link
    first_trust: float | None = 0.5  # eta from which a reading proposes a first colour
    first_agree: int = 2  # proposals agreeing within sigma that make the first colour
    proposals: int = 10  # proposals remembered
    near: int = 6  # where DON vouches: search this many steps either side of its reading
    track: int = 12  # where not: this many steps either side of this layer's own track
    agree_deg: float = 3.0  # a reading this near a vouched one teaches the colour
    relearn: int = 5  # vouched frames running against the colour before it is relearned
    disagree_deg: float = 6.0  # a reading this far from a vouched one counts against it
    offsets: tuple[float, ...] = (-2.0, 0.0, 2.0)  # sideways ray offsets, px
    fractions: tuple[float, float, int] = (0.3, 0.95, 14)  # ray samples: from, to (radii), count
    sigma: float = 35.0  # summed absolute RGB difference at which a match is exp(-1)
    min_match: float = 0.25  # a best ray matching less is no reading ...
    min_contrast: float = 0.15  # ... nor one this little above the rays' lower quartile
    max_share: float | None = 0.1  # a first colour matching more of the reach is the wall's
    learning_rate: float = 0.1  # the colour's running mean
    corridor_px: float = 4.0  # the line fit's half-width
    corridor_step: float = 0.5  # and its sample spacing, px


@dataclass(frozen=True)
class DONConfig:
    """DON for one link (`estimators.don.DON`). Defaults: the colour preset."""

    # Layers 1-3 (`MotionMask`; docs/decisions/don-smoothing-and-threshold.md).
    window: int = 10  # N, the frames in the input layer (paper: 10)
    gaussian: int = 0  # kernel size at 240 rows (paper: 15); 0: none
    threshold: int = 8  # grey levels a difference must exceed, any channel (paper: 12)
    working_height: int = 120  # rows of the working resolution
    min_area: int = 12  # fewest moving pixels that count as motion
    scene_change: float = 0.5  # a frame with this share moving is a cut, flash or noise
    # Location and path (docs/decisions/don-pivot.md, don-prediction.md).
    reach_back_px: float = 2.0  # how far a region may reach back past the pivot
    max_turn_deg: float = 45.0  # a larger jump in a frame restarts the path estimator
    guess_jump_deg: float = 10.0  # before the pivot: a guess jumping more restarts it
    vanish_deg: float = 1.5  # a link last turning this fast that leaves no pixel is hidden
    reseek: bool = True  # leave rigid edges out and replace a worse-explaining pivot
    # Layer 5, prediction (docs/decisions/don-prediction.md).
    trust_threshold: float = 0.0  # below this eta (and seen in part) predict; 0: off
    coast_decay: float = 0.8  # velocity kept from one predicted frame to the next
    partial: float = 0.6  # a reading under this share of the window's largest is partial
    predict_from_trust: float = 0.8  # roll on through missing frames only from this eta
    # The appearance layer, ours (docs/decisions/don-appearance.md).
    appearance: bool = True
    search_when_lost: bool = True  # search the whole range for the colour once lost
    tracker: TrackerConfig = field(default_factory=TrackerConfig)
    colour: AppearanceConfig = field(default_factory=AppearanceConfig)


@dataclass(frozen=True)
class LinkedDONConfig:
    """LinkedDON for a tree of 2-3 links (`estimators.don_links.LinkedDON`;
    `docs/decisions/linked-don.md`). Defaults: the colour preset."""

    # Layers 1-3 (`MotionMask`).
    window: int = 10
    gaussian: int = 15
    threshold: int = 4
    working_height: int = 120
    min_area: int = 12
    scene_change: float = 0.5
    # Object regression (`chain_fit`).
    band: float = 9.0  # px from a link's line at which a moving pixel stops counting
    margin_deg: float = 15.0  # how far past its joint range a link is searched for
    gate_deg: float = 15.0  # how far a joint may turn in one frame
    step_deg: float = 1.0  # the direction search's resolution
    stay: float = 0.5  # score lost per degree a joint moves from its last angle
    sweeps: int = 2  # coordinate-search passes per frame
    max_points: int = 600  # moving pixels the fit looks at (evenly subsampled beyond)
    recheck_every: int = 10  # fitted frames between searches of the whole ranges
    coarse_step_deg: float = 3.0  # their resolution, refined to step_deg about the best
    restarts: int = 6  # root angles those searches start from
    recheck_gain: float = 0.1  # how much more a pose found there must explain
    recheck_pixels: float = 0.5  # share of the window's most moving pixels a recheck needs
    # Lengths and the root pivot.
    bent_deg: float = 25.0  # a joint bent less than this has no measurable position
    length_memory: int = 60  # length measurements kept per link
    min_measurements: int = 3  # before the links are followed
    measure_every: int = 4  # fitted frames between measurements once the memory is full
    pivot_min_ends: int = 16  # far ends of moving trees seen before a first root pivot
    pivot_ends: int = 60  # far ends seen before the root pivot is fixed
    facing: float = 0.5  # share of a pivot's trees that must reach where the root can point
    range_margin_deg: float = 20.0  # where the root can point: its range plus this
    # The appearance layer, ours.
    appearance: bool = True
    appearance_min_length: float = 12.0  # px: a shorter link is too few pixels to read
    colour: AppearanceConfig = field(default_factory=lambda: AppearanceConfig(
        disagree_deg=math.inf, max_share=None, first_trust=None))


_DON_PRESETS = {"rgb": DONConfig(), "depth": DONConfig(gaussian=7)}
# No several-link depth scenario has been tuned on: depth uses the colour settings.
_LINKED_DON_PRESETS = {"rgb": LinkedDONConfig(), "depth": LinkedDONConfig()}


def don_preset(modality: str) -> DONConfig:
    """DON's settings for video of ``modality`` (``"rgb"`` or ``"depth"``, as
    `ImitateVideo-v0` shows it): depth keeps a 7x7 Gaussian, colour none."""
    return _DON_PRESETS[_checked(modality)]


def linked_don_preset(modality: str) -> LinkedDONConfig:
    """LinkedDON's settings for video of ``modality`` (``"rgb"`` or ``"depth"``)."""
    return _LINKED_DON_PRESETS[_checked(modality)]


def _checked(modality: str) -> str:
    if modality not in _DON_PRESETS:
        raise ValueError(f"modality must be one of {sorted(_DON_PRESETS)}, got {modality!r}")
    return modality


Config = TypeVar("Config", DONConfig, LinkedDONConfig, TrackerConfig, AppearanceConfig)


def override(config: Config, settings: Mapping[str, Any]) -> Config:
    """``config`` with ``settings`` replaced: field names, or ``tracker.NAME`` and
    ``colour.NAME`` for the nested ones. Raises TypeError naming an unknown field."""
    top: dict[str, Any] = {}
    nested: dict[str, dict[str, Any]] = {}
    for name, value in settings.items():
        outer, dot, inner = name.partition(".")
        if dot:
            nested.setdefault(outer, {})[inner] = value
        else:
            top[name] = value
    names = {f.name for f in dataclasses.fields(config)}
    unknown = sorted(set(top) - names) + sorted(f"{n}." for n in set(nested) - names)
    if unknown:
        raise TypeError(f"{type(config).__name__} has no field {', '.join(unknown)} "
                        f"(it has {', '.join(sorted(names))})")
    for outer, values in nested.items():
        top[outer] = override(top.get(outer, getattr(config, outer)), values)
    return dataclasses.replace(config, **top)


def parse_setting(text: str) -> tuple[str, Any]:
    """``NAME=VALUE`` (a Python literal, else the string) as (NAME, VALUE)."""
    name, _, value = text.partition("=")
    if not name or not value:
        raise ValueError(f"expected NAME=VALUE, got {text!r}")
    try:
        return name, ast.literal_eval(value)
    except (ValueError, SyntaxError):
        return name, value
