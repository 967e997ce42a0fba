"""`ClipSpec`, every knob of a synthetic clip, and the named scenarios of the paper."""

from __future__ import annotations

import hashlib
import json
import math
from dataclasses import asdict, dataclass, field, replace
from typing import Any, Literal

import numpy as np

from imimic_gym.clips.gestures import GESTURES, Gesture
from imimic_gym.clips.motion import MOTION_PROFILES, MotionProfile
from imimic_gym.clips.types import Clip
from imimic_gym.robots.planar import MAX_LINKS, ArmSpec, Control, Plane

__all__ = ["SCENARIOS", "SKIN_TONES", "Appearance", "ClipSpec", "get_scenario", "person_look",
           "scenario_names"]

Demonstrator = Literal["human", "servo", "hand"]
Background = Literal["plain", "textured", "cluttered"]
Occluder = Literal["none", "low", "high"]
Body = Literal["mannequin", "person"]
BODIES: tuple[str, ...] = ("mannequin", "person")

# Human segment lengths (m): upper arm, forearm, hand.
HUMAN_SEGMENTS = (0.30, 0.27, 0.17)
SERVO_LINK = 0.105  # the paper's paper link, 10.5 cm
# The hand (paper experiment 4): forearm with palm, thumb, index finger (m).
HAND_LINKS = (0.33, 0.06, 0.08)
DEG = math.pi / 180
RGB = tuple[float, float, float]
# Skin from light to dark (linear RGB), and hair: black, dark brown, brown, blond, red, grey.
SKIN_TONES = ((0.96, 0.80, 0.69), (0.87, 0.67, 0.53), (0.71, 0.51, 0.38),
              (0.55, 0.37, 0.26), (0.36, 0.23, 0.16))
HAIR_COLOURS = ((0.05, 0.04, 0.04), (0.16, 0.1, 0.06), (0.35, 0.22, 0.12),
                (0.75, 0.6, 0.35), (0.55, 0.22, 0.1), (0.6, 0.6, 0.6))
# Trousers: denim, black, grey, khaki, brown, navy.
TROUSER_COLOURS = ((0.15, 0.2, 0.35), (0.06, 0.06, 0.07), (0.3, 0.3, 0.32),
                   (0.55, 0.48, 0.33), (0.3, 0.2, 0.12), (0.08, 0.1, 0.2))


@dataclass(frozen=True)
class Appearance:
    """How a person's scene looks and is filmed, beyond `ClipSpec`'s own knobs: the
    domain randomisation of the CNN's training set. The defaults are the scene that a
    spec without an appearance renders (`ClipSpec.appearance` None).

    Colours are linear RGB in [0, 1]; lengths in metres, angles in degrees.

    Attributes:
        skin, shirt, pants: the person's colours.
        long_sleeves: the moving forearm in the shirt's colour instead of bare skin.
        wall, tile, floor: the backdrop's colours (``tile``: its checkerboard, drawn when
            the spec's background is textured or cluttered).
        tile_size: the side of a backdrop tile.
        clutter: how many shapes a cluttered background has on its wall.
        light_direction: the key light's direction (world x, y, z; the camera looks
            along +y, z is up).
        light_colour: multiplies the key light's diffuse and ambient colour.
        camera_height: the camera raised (negative: lowered) from its default place.
        camera_tilt: the camera pitched down (negative: up) from horizontal.
        camera_shift: the camera moved sideways (+: to the image's right), so the person
            sits further left in the frame.
        fovy: the camera's vertical field of view.
        hair: the hair's colour (the ``person`` body only, as the fields below).
        long_hair: hair down to the shoulders instead of short.
        shoes: the shoes' colour.
        build: the torso's and limbs' girth, a factor on the defaults (0.85-1.2);
            the bones' lengths stay.
    """

    skin: RGB = (0.87, 0.67, 0.53)
    shirt: RGB = (0.22, 0.36, 0.66)
    pants: RGB = (0.2, 0.2, 0.25)
    long_sleeves: bool = False
    wall: RGB = (0.78, 0.8, 0.84)
    tile: RGB = (0.55, 0.6, 0.68)
    floor: RGB = (0.45, 0.42, 0.4)
    tile_size: float = 0.3
    clutter: int = 7
    light_direction: tuple[float, float, float] = (-0.25, 0.75, -1.0)
    light_colour: RGB = (1.0, 1.0, 1.0)
    camera_height: float = 0.0
    camera_tilt: float = 0.0
    camera_shift: float = 0.0
    fovy: float = 45.0
    hair: RGB = (0.16, 0.1, 0.06)
    long_hair: bool = False
    shoes: RGB = (0.08, 0.08, 0.09)
    build: float = 1.0

    def __post_init__(self) -> None:
        for name in ("skin", "shirt", "pants", "wall", "tile", "floor", "light_colour",
                     "light_direction", "hair", "shoes"):
            value = tuple(float(v) for v in getattr(self, name))  # JSON gives lists
            object.__setattr__(self, name, value)
            if len(value) != 3 or not all(math.isfinite(v) for v in value):
                raise ValueError(f"appearance {name} must be 3 finite numbers, got {value}")
            if name != "light_direction" and not all(0.0 <= v <= 1.0 for v in value):
                raise ValueError(f"appearance {name} must be RGB in [0, 1], got {value}")
        if not any(self.light_direction):
            raise ValueError("appearance light_direction must not be zero")
        if not (isinstance(self.clutter, int) and 0 <= self.clutter <= 100):
            raise ValueError(f"appearance clutter must be 0 to 100 shapes, got {self.clutter!r}")
        if not 0.02 <= self.tile_size <= 2.0:
            raise ValueError(f"appearance tile_size must be 0.02-2 m, got {self.tile_size}")
        if not 10.0 <= self.fovy <= 120.0:
            raise ValueError(f"appearance fovy must be 10-120 degrees, got {self.fovy}")
        if not 0.85 <= self.build <= 1.2:
            raise ValueError(f"appearance build must be 0.85-1.2, got {self.build}")
        if not -60.0 <= self.camera_tilt <= 60.0:
            raise ValueError(f"appearance camera_tilt must be -60..60 degrees, got "
                             f"{self.camera_tilt}")


def person_look(seed: int) -> Appearance:
    """The person a ``person`` spec without an appearance shows at ``seed``: skin tone,
    hair colour and length, shirt, sleeves, trousers, shoes and build drawn from a stream
    of its own (the motion's draws stay as they are); the backdrop, light and camera are
    the defaults."""
    rng = np.random.default_rng((seed, 0x9E75))

    def rgb(values: np.ndarray) -> RGB:
        r, g, b = (round(float(v), 3) for v in np.clip(values, 0.0, 1.0))
        return r, g, b

    skin = np.array(SKIN_TONES[rng.integers(len(SKIN_TONES))]) + rng.uniform(-0.04, 0.04, 3)
    hair = np.array(HAIR_COLOURS[rng.integers(len(HAIR_COLOURS))]) * rng.uniform(0.85, 1.15)
    grey = rng.uniform(0.1, 0.8)  # a shirt of any hue, saturated as clothes are
    shirt = grey + rng.uniform(0.45, 0.8) * (rng.uniform(0.0, 1.0, 3) - grey)
    trousers = np.array(TROUSER_COLOURS[rng.integers(len(TROUSER_COLOURS))])
    return Appearance(skin=rgb(skin), hair=rgb(hair), long_hair=bool(rng.random() < 0.4),
                      shirt=rgb(shirt), long_sleeves=bool(rng.random() < 0.3),
                      pants=rgb(trousers * rng.uniform(0.8, 1.2)),
                      shoes=rgb(np.full(3, rng.uniform(0.05, 0.8)) + rng.uniform(-0.05, 0.05, 3)),
                      build=round(float(rng.uniform(0.9, 1.15)), 3))


# Appearance fields only the ``person`` body shows: a spec's key leaves them out while they
# have their defaults, so the keys of specs written before they existed stay.
PERSON_APPEARANCE = ("hair", "long_hair", "shoes", "build")


@dataclass(frozen=True)
class ClipSpec:
    """Everything that determines a synthetic clip; equal specs give identical clips.

    Attributes:
        demonstrator: ``"human"`` (a standing person filmed from the front, arm moving in
            the image plane), ``"servo"`` (the paper's servo arm filmed from above) or
            ``"hand"`` (the person's forearm, thumb and index finger: the paper's
            experiment 4).
        n_links: moving links, 1 to 3. Human: 1 = forearm (elbow), 2 = + shoulder,
            3 = + wrist. Servo: a chain of n paper links. Hand: 3 (forearm, and thumb and
            index finger both on it).
        motion: ``"sinusoid"``, ``"spline"`` (smooth random) or ``"fast"`` (fast random)
            for the arm in the image plane; or a gesture of the spatial arm
            (`clips.gestures`: ``"reach"``, ``"cup"``, ``"raise"``, ``"curl"``,
            ``"wave"``, ``"mix"``), a human demonstrator's whole arm moving in 3-D, whose
            clips carry 3-D truth and whose ``n_links`` (2 or 3) are the planar reading
            of its keypoints.
        background: ``"plain"``, ``"textured"`` or ``"cluttered"`` (shapes on the wall and
            a moving distractor ball).
        lighting: light intensity in [0.2, 1.0]; the paper reports DON works above 0.5.
        camera_distance: camera to demonstrator, metres.
        sway: body sway amplitude, 0 = still, 1 = 4 cm and 3 degrees of torso roll.
        occluder: a board crossing in front of the arm: ``"none"``, ``"low"``, ``"high"``.
        height, width: image size in pixels.
        fps: frames per second.
        n_frames: clip length in frames.
        seed: seeds the motion, occluder, distractor and clutter.
        appearance: colours, backdrop, light and camera placement of a person's scene
            (`Appearance`); None (the default) is the scene every named scenario uses,
            and leaves the spec's `key` as it was before the field existed.
        body: the human demonstrator's figure: ``"mannequin"`` (capsules, no face or
            hands: the paper scenarios') or ``"person"`` (a face, hair, hands with
            fingers, human proportions; a ``"human"`` demonstrator's, the planar arm or
            the spatial). A person without an appearance is dressed by its seed
            (`person_look`).
        name: the scenario's name; not part of the clip's identity.
    """

    demonstrator: Demonstrator = "human"
    n_links: int = 1
    motion: MotionProfile | Gesture = "sinusoid"
    background: Background = "plain"
    lighting: float = 1.0
    camera_distance: float = 2.2
    sway: float = 0.0
    occluder: Occluder = "none"
    height: int = 240
    width: int = 320
    fps: float = 30.0
    n_frames: int = 150
    seed: int = 0
    appearance: Appearance | None = None
    body: Body = "mannequin"
    name: str = field(default="custom", compare=False)

    def __post_init__(self) -> None:
        if not (isinstance(self.n_links, int) and 1 <= self.n_links <= MAX_LINKS):
            raise ValueError(
                f"n_links must be an integer from 1 to {MAX_LINKS}, got {self.n_links!r}"
            )
        for name, value, allowed in (
            ("demonstrator", self.demonstrator, ("human", "servo", "hand")),
            ("motion", self.motion, MOTION_PROFILES + GESTURES),
            ("body", self.body, BODIES),
            ("background", self.background, ("plain", "textured", "cluttered")),
            ("occluder", self.occluder, ("none", "low", "high")),
        ):
            if value not in allowed:
                raise ValueError(f"{name} must be one of {allowed}, got {value!r}")
        if self.demonstrator == "hand" and self.n_links != 3:
            raise ValueError(f"the hand has 3 joints (forearm, thumb, index finger); "
                             f"n_links must be 3, got {self.n_links}")
        if self.spatial and (self.demonstrator != "human" or self.n_links == 1):
            raise ValueError(f"the spatial arm (motion {self.motion!r}) is a human "
                             f"demonstrator's with 2 or 3 links; got demonstrator "
                             f"{self.demonstrator!r} with {self.n_links}")
        if self.body == "person" and self.demonstrator != "human":
            raise ValueError(f"the person body is a human demonstrator's; got demonstrator "
                             f"{self.demonstrator!r}")
        if not 0.2 <= self.lighting <= 1.0:
            raise ValueError(f"lighting must be in [0.2, 1.0], got {self.lighting}")
        for name in ("height", "width", "n_frames"):
            value = getattr(self, name)
            if not (isinstance(value, int) and value > 0):
                raise ValueError(f"{name} must be a positive integer, got {value!r}")
        if not (isinstance(self.seed, (int, np.integer)) and self.seed >= 0):
            raise ValueError(f"seed must be a whole number >= 0 (numpy's generators take no "
                             f"negative seeds), got {self.seed!r}")
        if not self.fps > 0:
            raise ValueError(f"fps must be positive, got {self.fps}")
        if not self.camera_distance > 0:
            raise ValueError(f"camera_distance must be positive metres, got {self.camera_distance}")
        if not self.sway >= 0:
            raise ValueError(f"sway must be >= 0, got {self.sway}")
        if isinstance(self.appearance, dict):  # a spec read back from JSON
            object.__setattr__(self, "appearance", Appearance(**self.appearance))
        if self.appearance is not None:
            if not isinstance(self.appearance, Appearance):
                raise ValueError(f"appearance must be an Appearance or None, got "
                                 f"{type(self.appearance).__name__}")
            if self.demonstrator == "servo":
                raise ValueError("appearance dresses a person's scene; the servo "
                                 "demonstrator has none")

    def replace(self, **changes: Any) -> ClipSpec:
        return replace(self, **changes)

    def record(self) -> dict[str, Any]:
        """The fields that determine the pixels, JSON-ready: all but the name, and the
        appearance only when set. ``ClipSpec(**spec.record()) == spec``."""
        fields = asdict(self)
        fields.pop("name")
        if self.appearance is None:
            fields.pop("appearance")
        else:
            defaults = Appearance()
            for name in PERSON_APPEARANCE:
                if getattr(self.appearance, name) == getattr(defaults, name):
                    fields["appearance"].pop(name)
        if self.body == "mannequin":
            fields.pop("body")
        return fields

    def key(self) -> str:
        """A content hash of everything that determines the pixels (not the name)."""
        return hashlib.sha256(json.dumps(self.record(), sort_keys=True).encode()).hexdigest()[:20]

    @property
    def spatial(self) -> bool:
        """Does the arm move in 3-D (a gesture, `clips.gestures`)?"""
        return self.motion in GESTURES

    # Geometry that the demonstrator scene and the matching robot arm share.
    @property
    def link_parents(self) -> tuple[int, ...]:
        """Each moving link's parent (-1: the fixed reference). A chain, except the hand,
        whose thumb and index finger both sit on the forearm."""
        return (-1, 0, 0) if self.demonstrator == "hand" else tuple(range(-1, self.n_links - 1))

    @property
    def link_lengths(self) -> tuple[float, ...]:
        if self.demonstrator == "hand":
            return HAND_LINKS
        if self.demonstrator == "servo":
            return (SERVO_LINK,) * self.n_links
        if self.n_links == 1:
            return (HUMAN_SEGMENTS[1],)
        return HUMAN_SEGMENTS[: self.n_links]

    @property
    def joint_ranges(self) -> tuple[tuple[float, float], ...]:
        """Joint limits in rad, shared by the demonstrator's motion and the robot."""
        if self.demonstrator == "servo":
            return ((-60 * DEG, 60 * DEG),) * self.n_links  # the paper's 120 degree servo
        if self.spatial:  # the planar reading of a 3-D arm takes any image direction
            return ((-math.pi, math.pi),) * self.n_links
        if self.demonstrator == "hand":  # forearm, thumb, index: the fingers never overlap
            return ((0.0, 120 * DEG), (30 * DEG, 90 * DEG), (-30 * DEG, 20 * DEG))
        shoulder, elbow, wrist = (0.0, 150 * DEG), (0.0, 120 * DEG), (-60 * DEG, 60 * DEG)
        return ((elbow,), (shoulder, elbow), (shoulder, elbow, wrist))[self.n_links - 1]

    @property
    def reference_direction(self) -> float:
        """Image-plane direction (rad, CCW from image right) of the fixed reference link."""
        if self.demonstrator == "servo":
            return math.pi / 2  # the servo's zero mark points up the image
        if self.demonstrator == "hand" or self.n_links == 1:
            return 0.0  # the upper arm, held out sideways
        return -math.pi / 2  # the torso, pointing down

    def robot_arm(self, control: Control = "position") -> ArmSpec:
        """A robot arm that matches this demonstrator's links, ranges and viewpoint."""
        plane: Plane
        if self.demonstrator == "servo":
            masses, damping, reference = (0.02,) * self.n_links, 2e-4, 0.0
            plane, radius = "horizontal", 0.006
        elif self.demonstrator == "hand":
            masses, damping, reference = (0.8, 0.05, 0.05), 2e-3, HUMAN_SEGMENTS[0]
            plane, radius = "vertical", 0.018
        else:
            masses = (0.8,) if self.n_links == 1 else (1.2, 0.8, 0.4)[: self.n_links]
            damping, plane, radius = 0.05, "vertical", 0.025
            reference = HUMAN_SEGMENTS[0] if self.n_links == 1 else 0.45
        max_torque = 0.3 if self.demonstrator == "servo" else 25.0
        return ArmSpec(
            link_lengths=self.link_lengths,
            link_masses=masses,
            joint_ranges=self.joint_ranges,
            joint_damping=damping,
            plane=plane,
            reference_direction=self.reference_direction,
            reference_length=reference,
            control=control,
            link_radius=radius,
            max_torque=max_torque,
            parents=self.link_parents,
        )


SCENARIOS: dict[str, ClipSpec] = {
    spec.name: spec
    for spec in (
        ClipSpec(name="default"),
        # Paper experiment 1: fast random motion, body sway, a busy background.
        ClipSpec(name="exp1-noisy-fast", motion="fast", background="cluttered", sway=1.0,
                 lighting=0.7),
        # Paper experiment 2: the one-link servo filmed from 32 cm above, static background.
        ClipSpec(name="exp2-servo", demonstrator="servo", motion="spline",
                 camera_distance=0.32),
        # Paper experiment 3: a standing person's forearm, slight sway, moving background,
        # three levels of occlusion.
        *(
            ClipSpec(name=f"exp3-forearm-{level}", motion="spline", background="cluttered",
                     sway=0.3, occluder=level)
            for level in ("none", "low", "high")
        ),
        # Paper experiment 4: forearm, thumb and index finger, filmed closer.
        ClipSpec(name="exp4-hand", demonstrator="hand", n_links=3, motion="spline",
                 camera_distance=1.2),
        ClipSpec(name="chain-2", n_links=2, motion="spline", background="textured"),
        ClipSpec(name="chain-3", n_links=3, motion="spline", background="textured"),
        # The arm in 3-D (issue 36): a person facing the camera, one gesture each, and
        # "spatial" mixing them (a different sequence per seed).
        *(ClipSpec(name=f"spatial-{gesture}", motion=gesture, n_links=2, body="person",
                   camera_distance=1.7)
          for gesture in ("reach", "cup", "raise", "curl", "wave")),
        ClipSpec(name="spatial", motion="mix", n_links=2, body="person", camera_distance=1.7),
    )
}


def scenario_names() -> list[str]:
    return sorted(SCENARIOS)


def get_scenario(name: str, **overrides: Any) -> ClipSpec:
    """The named scenario's spec, with any field overridden (``seed=3, n_frames=60``)."""
    if name not in SCENARIOS:
        raise ValueError(f"unknown scenario {name!r}; valid names: {', '.join(scenario_names())}")
    return SCENARIOS[name].replace(**overrides) if overrides else SCENARIOS[name]


def robot_for_clip(clip: Clip, control: Control = "position") -> ArmSpec:
    """A robot matching ``clip``: its demonstrator's arm, with the reference direction
    and joint ranges of ``clip.meta`` where the clip states them (recorded video)."""
    arm = ClipSpec(demonstrator=clip.meta.get("demonstrator", "human"),
                   n_links=clip.n_links).robot_arm(control)
    changes: dict[str, Any] = {}
    if "reference_direction" in clip.meta:
        changes["reference_direction"] = float(clip.meta["reference_direction"])
    if "joint_ranges" in clip.meta:
        changes["joint_ranges"] = tuple((float(lo), float(hi))
                                        for lo, hi in clip.meta["joint_ranges"])
    return replace(arm, **changes) if changes else arm
