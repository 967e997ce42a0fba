"""The demonstrator's scene as MJCF: a person (or the paper's servo arm), a backdrop,
lights, an occluding board and a distractor, all posed kinematically per frame.

Naming contract with the renderer (`synthetic.py`):
- joints ``q1..qn`` are the demonstrator's arm joints, ``sway_x``/``sway_roll`` the body;
  the spatial arm's joints are named as `clips.gestures.SPATIAL_JOINTS` instead;
- sites ``kp_<name>`` are the keypoints, in ``ClipSpec`` order; the spatial arm adds
  ``arm_<name>`` for the points of `spatial.ARM_POINTS` that are not keypoints;
- the moving links' geoms, and only they, are in geom group ``MOVING_GROUP``, so a pass
  can draw them alone;
- mocap bodies ``occluder`` and ``distractor``; the camera is ``film``.
"""

from __future__ import annotations

import math

import numpy as np

from imimic_gym.clips.gestures import SPATIAL_JOINT_RANGES, SPATIAL_JOINTS
from imimic_gym.clips.scenarios import HUMAN_SEGMENTS, Appearance, ClipSpec, person_look
from imimic_gym.robots.planar import fmt, link_frame_quat

__all__ = ["ARM_SITES", "MOVING_GROUP", "camera_pose", "keypoint_names", "scene_mjcf",
           "workspace"]

MOVING_GROUP = 1
SHOULDER = np.array([0.21, -0.02, 1.42])  # the moving arm's shoulder, world frame
ELBOW = SHOULDER + np.array([HUMAN_SEGMENTS[0], 0.0, 0.0])  # with the upper arm held out
HIP_HEIGHT = 0.95
SKIN, SHIRT, PANTS = "0.87 0.67 0.53 1", "0.22 0.36 0.66 1", "0.2 0.2 0.25 1"
# The spatial arm's sites of `spatial.ARM_POINTS`, in that order.
ARM_SITES = ("kp_shoulder", "kp_elbow", "kp_wrist", "arm_hand", "arm_other_shoulder",
             "arm_hip", "arm_other_hip")
HEAD = 0.655  # the person's head centre above the hips, m
HAND_KNUCKLES = 0.09  # wrist to the index finger's knuckle (the pose model's "hand"), m


def keypoint_names(spec: ClipSpec) -> tuple[str, ...]:
    if spec.demonstrator == "human":
        return ("shoulder", "elbow", "wrist", "hand_tip")
    if spec.demonstrator == "hand":
        return ("elbow", "wrist", "thumb_tip", "index_tip")
    return ("pivot", *(f"joint{i + 2}" for i in range(spec.n_links - 1)), "tip")


def _chain_points(spec: ClipSpec, angles: np.ndarray) -> np.ndarray:
    """The base joint and every segment's end in the arm plane, (K, 2) metres, for
    ``angles``: the geometry the workspace is measured from."""
    parents: tuple[int, ...]
    if spec.demonstrator == "human":  # the whole arm; the joints sit on some segments
        lengths, parents = list(HUMAN_SEGMENTS), (-1, 0, 1)
        first = 1 if spec.n_links == 1 else 0
        joints = np.zeros(3)
        joints[first : first + spec.n_links] = angles
    else:
        lengths, parents, joints = list(spec.link_lengths), spec.link_parents, angles
    direction: list[float] = []
    ends: list[np.ndarray] = []
    for i, parent in enumerate(parents):
        direction.append((direction[parent] if parent >= 0 else spec.reference_direction)
                         + joints[i])
        start = ends[parent] if parent >= 0 else np.zeros(2)
        ends.append(start + lengths[i] * np.array([np.cos(direction[i]), np.sin(direction[i])]))
    return np.vstack([np.zeros(2), *ends])


def workspace(spec: ClipSpec) -> tuple[np.ndarray, float]:
    """Centre (world, m) and radius (m) of the region the arm sweeps, from its ranges."""
    if spec.spatial:  # the whole arm about the shoulder, forward and sideways and up
        return SHOULDER + np.array([0.2, -0.2, -0.05]), 0.6
    ranges = np.asarray(spec.joint_ranges)
    samples = [
        _chain_points(spec, ranges[:, 0] + f * (ranges[:, 1] - ranges[:, 0]))
        for f in np.linspace(0, 1, 7)
    ]
    points = np.concatenate(samples)[1:]
    centre2d = (points.min(axis=0) + points.max(axis=0)) / 2
    radius = float(np.max(np.linalg.norm(points - centre2d, axis=1)))
    if spec.demonstrator == "servo":
        return np.array([centre2d[0], centre2d[1], 0.024]), radius
    base = SHOULDER if spec.demonstrator == "human" else ELBOW
    return base + np.array([centre2d[0], 0.0, centre2d[1]]), radius


def _look(spec: ClipSpec) -> Appearance | None:
    """The appearance the scene shows: the spec's, or for a person without one the
    person its seed dresses (`person_look`)."""
    if spec.appearance is None and spec.body == "person":
        return person_look(spec.seed)
    return spec.appearance


def _person_materials(look: Appearance) -> str:
    """The colours only the ``person`` body has: hair, shoes, the face's details."""
    skin = np.array(look.skin)
    return f"""
    <material name="hair" rgba="{fmt((*look.hair, 1.0))}"/>
    <material name="shoes" rgba="{fmt((*look.shoes, 1.0))}"/>
    <material name="skin_shade" rgba="{fmt((*(0.8 * skin), 1.0))}"/>
    <material name="lips" rgba="{fmt((*(skin * np.array([0.75, 0.45, 0.45])), 1.0))}"/>
    <material name="eye_white" rgba="0.93 0.93 0.9 1"/>
    <material name="pupil" rgba="0.08 0.06 0.05 1"/>"""


def _materials(appearance: Appearance | None) -> str:
    if appearance is None:
        wall, tile, skin, shirt, pants, floor = (
            "0.78 0.8 0.84 1", "0.55 0.6 0.68 1", SKIN, SHIRT, PANTS, "0.45 0.42 0.4 1")
    else:
        wall, tile, skin, shirt, pants, floor = (
            fmt((*colour, 1.0)) for colour in (appearance.wall, appearance.tile,
                                               appearance.skin, appearance.shirt,
                                               appearance.pants, appearance.floor))
    return f"""
    <material name="wall" rgba="{wall}"/>
    <material name="tile" rgba="{tile}"/>
    <material name="skin" rgba="{skin}"/>
    <material name="shirt" rgba="{shirt}"/>
    <material name="pants" rgba="{pants}"/>
    <material name="floor" rgba="{floor}"/>
    <material name="table" rgba="0.3 0.27 0.25 1"/>
    <material name="servo" rgba="0.12 0.12 0.14 1"/>
    <material name="paper" rgba="0.98 0.98 0.98 1"/>
    <material name="board" rgba="0.55 0.38 0.22 1"/>
    <material name="distractor" rgba="0.85 0.15 0.12 1"/>"""


def _tiles(spec: ClipSpec) -> str:
    """A checkerboard of flat tiles on the backdrop. Geometry, not a texture: texture
    sampling costs the software renderer ~3 ms a frame, a few dozen quads almost nothing."""
    if spec.background == "plain":
        return ""
    tiles = []
    if spec.demonstrator != "servo":
        if spec.appearance is None:
            size, (nx, nz) = 0.3, (14, 9)
        else:  # the same wall area, 4.2 m by 2.7 m, in tiles of the appearance's size
            size = spec.appearance.tile_size
            nx, nz = math.ceil(4.2 / size), math.ceil(2.7 / size)
        for i in range(nx):
            for k in range(nz):
                if (i + k) % 2 == 0:
                    pos = (-2.1 + (i + 0.5) * size, 0.59, (k + 0.5) * size)
                    tiles.append(f'<geom name="tile{i}_{k}" type="box" pos="{fmt(pos)}" '
                                 f'size="{size / 2} 0.005 {size / 2}" material="tile"/>')
    else:
        size, n = 0.04, 10
        for i in range(n):
            for k in range(n):
                if (i + k) % 2 == 0:
                    pos = (-0.2 + (i + 0.5) * size, -0.15 + (k + 0.5) * size, 0.0002)
                    tiles.append(f'<geom name="tile{i}_{k}" type="box" pos="{fmt(pos)}" '
                                 f'size="{size / 2} {size / 2} 0.0002" material="tile"/>')
    return "\n    ".join(tiles)


def _arm_chain(spec: ClipSpec, shoulder: np.ndarray) -> tuple[str, str]:
    """The arm as a chain (upper arm, forearm, hand) with n_links joints: the MJCF that
    opens its bodies, and the text that closes them."""
    sleeves = spec.appearance is not None and spec.appearance.long_sleeves
    segments = [("upper_arm", HUMAN_SEGMENTS[0], 0.045, "shirt"),
                ("forearm", HUMAN_SEGMENTS[1], 0.037, "shirt" if sleeves else "skin"),
                ("hand", HUMAN_SEGMENTS[2], 0.033, "skin")]
    s = shoulder
    first_joint = 1 if spec.n_links == 1 else 0
    person = spec.body == "person"
    if person:  # the person's limbs along -z, turned onto the link's +x, palm to the camera
        look = _look(spec) or Appearance()
        shapes = (_person_arm(look, HUMAN_SEGMENTS[0], HUMAN_SEGMENTS[1], moving=False),
                  _person_arm(look, HUMAN_SEGMENTS[0], HUMAN_SEGMENTS[1], moving=True))
    chain, closing = "", ""
    for i, (name, length, radius, material) in enumerate(segments):
        pos = fmt(s) if i == 0 else fmt((segments[i - 1][1], 0, 0))
        quat = f'quat="{fmt(link_frame_quat("vertical", spec.reference_direction))}"' if i == 0 else ""
        joint_index = i - first_joint
        joint = ""
        if 0 <= joint_index < spec.n_links:
            lo, hi = spec.joint_ranges[joint_index]
            joint = f'<joint name="q{joint_index + 1}" axis="0 0 1" range="{lo:.12g} {hi:.12g}"/>'
        group = f'group="{MOVING_GROUP}"' if i >= first_joint else ""
        keypoint = ("shoulder", "elbow", "wrist")[i]
        shape = (f'<body name="{name}_shape" euler="0 {-math.pi / 2:.12g} 0">'
                 f'{shapes[i >= first_joint][i]}</body>' if person else
                 f'<geom name="{name}" type="capsule" fromto="0 0 0 {length} 0 0" '
                 f'size="{radius}" material="{material}" {group}/>')
        chain += (
            f'<body name="{name}" pos="{pos}" {quat}>{joint}'
            f'<site name="kp_{keypoint}" size="0.01"/>{shape}'
        )
        closing += "</body>"
    tip = 0.17 if person else HUMAN_SEGMENTS[2] + 0.033
    chain += f'<site name="kp_hand_tip" pos="{tip} 0 0" size="0.01"/>'
    return chain, closing


def _hand_tree(spec: ClipSpec, shoulder: np.ndarray) -> tuple[str, str]:
    """The paper's experiment 4: the upper arm held out, the forearm (with the palm)
    turning at the elbow, and the thumb and the index finger each turning at the wrist."""
    forearm, thumb, index = spec.link_lengths
    (lo1, hi1), (lo2, hi2), (lo3, hi3) = spec.joint_ranges
    quat = fmt(link_frame_quat("vertical", spec.reference_direction))
    moving = f'group="{MOVING_GROUP}"'
    finger = (
        '<body name="{name}" pos="{base} 0 0"><joint name="q{q}" axis="0 0 1" '
        'range="{lo:.12g} {hi:.12g}"/><geom name="{name}" type="capsule" '
        'fromto="0 0 0 {length} 0 0" size="{radius}" material="skin" {moving}/>'
        '<site name="kp_{name}_tip" pos="{length} 0 0" size="0.005"/></body>'
    )
    chain = (
        f'<body name="upper_arm" pos="{fmt(shoulder)}" quat="{quat}">'
        f'<geom name="upper_arm" type="capsule" fromto="0 0 0 {HUMAN_SEGMENTS[0]} 0 0" '
        f'size="0.045" material="shirt"/>'
        f'<body name="forearm" pos="{HUMAN_SEGMENTS[0]} 0 0">'
        f'<joint name="q1" axis="0 0 1" range="{lo1:.12g} {hi1:.12g}"/>'
        f'<site name="kp_elbow" size="0.01"/>'
        f'<geom name="forearm" type="capsule" fromto="0 0 0 {forearm - 0.06} 0 0" '
        f'size="0.037" material="skin" {moving}/>'
        f'<geom name="palm" type="box" pos="{forearm - 0.03} 0 0" size="0.035 0.03 0.012" '
        f'material="skin" {moving}/>'
        f'<site name="kp_wrist" pos="{forearm} 0 0" size="0.01"/>'
        + finger.format(name="thumb", base=forearm, q=2, lo=lo2, hi=hi2, length=thumb,
                        radius=0.011, moving=moving)
        + finger.format(name="index", base=forearm, q=3, lo=lo3, hi=hi3, length=index,
                        radius=0.010, moving=moving)
    )
    return chain, "</body></body>"


def _human_body(spec: ClipSpec) -> str:
    """Torso, head, legs, the still arm, and the moving arm chain with its joints."""
    s = SHOULDER - np.array([0.0, 0.0, HIP_HEIGHT])
    if spec.spatial:
        chain, closing = _spatial_arm(spec, s), ""
    else:
        chain, closing = (_hand_tree(spec, s) if spec.demonstrator == "hand"
                          else _arm_chain(spec, s))

    return f"""
    <body name="root" pos="0 0 0">
      <joint name="sway_x" type="slide" axis="1 0 0"/>
      <geom name="leg_l" type="capsule" fromto="-0.09 0 0.05 -0.1 0 {HIP_HEIGHT}" size="0.07" material="pants"/>
      <geom name="leg_r" type="capsule" fromto="0.09 0 0.05 0.1 0 {HIP_HEIGHT}" size="0.07" material="pants"/>
      <body name="upper_body" pos="0 0 {HIP_HEIGHT}">
        <joint name="sway_roll" axis="0 -1 0"/>
        <geom name="torso" type="ellipsoid" pos="0 0 0.25" size="0.17 0.1 0.3" material="shirt"/>
        <geom name="neck" type="capsule" fromto="0 0 0.5 0 0 0.6" size="0.045" material="skin"/>
        <geom name="head" type="sphere" pos="0 0 0.7" size="0.11" material="skin"/>
        <geom name="still_upper_arm" type="capsule" fromto="-0.21 0 0.47 -0.24 0 0.18" size="0.045" material="shirt"/>
        <geom name="still_forearm" type="capsule" fromto="-0.24 0 0.18 -0.25 0 -0.08" size="0.037" material="skin"/>
        {chain}{closing}{_torso_sites(s) if spec.spatial else ""}
      </body>
    </body>"""


def _torso_sites(shoulder: np.ndarray) -> str:
    """The torso's points of `spatial.ARM_POINTS` (upper-body frame): the other
    shoulder, mirrored, and the hip joints below the shoulders, in the shoulders' plane."""
    x, y, _ = shoulder
    return (f'<site name="arm_other_shoulder" pos="{fmt((-x, y, shoulder[2]))}" size="0.01"/>'
            f'<site name="arm_hip" pos="{fmt((0.1, y, 0.0))}" size="0.01"/>'
            f'<site name="arm_other_hip" pos="{fmt((-0.1, y, 0.0))}" size="0.01"/>')


def _joint(name: str) -> str:
    lo, hi = SPATIAL_JOINT_RANGES[SPATIAL_JOINTS.index(name)]
    axis = {"shoulder_flexion": "-1 0 0", "shoulder_abduction": "0 -1 0",
            "shoulder_rotation": "0 0 -1", "elbow_flexion": "-1 0 0",
            "wrist_flexion": "0 1 0"}[name]
    return f'<joint name="{name}" axis="{axis}" range="{lo:.12g} {hi:.12g}"/>'


def _spatial_arm(spec: ClipSpec, shoulder: np.ndarray) -> str:
    """The left arm in 3-D (`clips.gestures`), hanging down at zero: the shoulder's three
    joints in one body (MuJoCo applies a body's joints in order, each about its axis as
    the ones before have turned it), then the elbow and the wrist. The person faces -y,
    so the left arm's outward is +x and its forward -y."""
    upper, fore, _ = HUMAN_SEGMENTS
    person = spec.body == "person"
    look = _look(spec) or Appearance()
    upper_geoms, fore_geoms, hand_geoms = (_person_arm(look, upper, fore) if person
                                           else _mannequin_arm(look, upper, fore))
    tip = 0.17 if person else HUMAN_SEGMENTS[2] + 0.033  # inside the fingers' end
    return (
        f'<body name="upper_arm" pos="{fmt(shoulder)}">'
        + "".join(_joint(n) for n in SPATIAL_JOINTS[:3])
        + f'<site name="kp_shoulder" size="0.01"/>{upper_geoms}'
        f'<body name="forearm" pos="0 0 {-upper}">{_joint("elbow_flexion")}'
        f'<site name="kp_elbow" size="0.01"/>{fore_geoms}'
        f'<body name="hand" pos="0 0 {-fore}">{_joint("wrist_flexion")}'
        f'<site name="kp_wrist" size="0.01"/>'
        f'<site name="arm_hand" pos="0 0 {-HAND_KNUCKLES}" size="0.01"/>'
        f'<site name="kp_hand_tip" pos="0 0 {-tip}" size="0.01"/>{hand_geoms}'
        "</body></body></body>"
    )


def _mannequin_arm(look: Appearance, upper: float, fore: float) -> tuple[str, str, str]:
    """The mannequin's capsules (as its planar arm's), along -z: upper arm, forearm, hand."""
    moving = f'group="{MOVING_GROUP}"'
    sleeve = "shirt" if look.long_sleeves else "skin"
    return (f'<geom name="upper_arm" type="capsule" fromto="0 0 0 0 0 {-upper}" size="0.045" '
            f'material="shirt" {moving}/>',
            f'<geom name="forearm" type="capsule" fromto="0 0 0 0 0 {-fore}" size="0.037" '
            f'material="{sleeve}" {moving}/>',
            f'<geom name="hand" type="capsule" fromto="0 0 0 0 0 {-HUMAN_SEGMENTS[2]}" '
            f'size="0.033" material="skin" {moving}/>')


def _person_arm(look: Appearance, upper: float, fore: float, moving: bool = True,
                prefix: str = "") -> tuple[str, str, str]:
    """A person's arm along -z from the shoulder (hanging, palm towards the body's middle
    at -x, thumb forward at -y): a sleeve over the upper arm, a forearm tapering to the
    wrist, a palm with a block of fingers and a thumb. Girth scales with the build."""
    b = look.build
    group = f'group="{MOVING_GROUP}"' if moving else ""
    sleeve_end = -upper if look.long_sleeves else -0.55 * upper
    forearm = "shirt" if look.long_sleeves else "skin"

    def geom(name: str, spec: str, material: str) -> str:
        return f'<geom name="{prefix}{name}" {spec} material="{material}" {group}/>'

    upper_geoms = geom("upper_arm", f'type="capsule" fromto="0 0 0 0 0 {sleeve_end:.4f}" '
                                    f'size="{0.05 * b:.4f}"', "shirt")
    if not look.long_sleeves:
        upper_geoms += geom("upper_arm_skin", f'type="capsule" fromto="0 0 {sleeve_end:.4f} '
                                              f'0 0 {-upper}" size="{0.042 * b:.4f}"', "skin")
    fore_geoms = (
        geom("forearm", f'type="capsule" fromto="0 0 0 0 0 {-0.45 * fore:.4f}" '
                        f'size="{0.038 * b:.4f}"', forearm)
        + geom("forearm_wrist", f'type="capsule" fromto="0 0 {-0.45 * fore:.4f} 0 0 '
                                f'{-fore + 0.02:.4f}" size="{0.029 * b:.4f}"', forearm))
    hand_geoms = (
        geom("palm", 'type="box" pos="0 0 -0.05" size="0.014 0.04 0.048"', "skin")
        + geom("fingers", 'type="box" pos="0 0 -0.135" size="0.011 0.037 0.045"', "skin")
        + geom("finger_gaps", 'type="box" pos="0.0 0 -0.15" size="0.0115 0.0015 0.03"',
               "skin_shade")
        + geom("thumb", 'type="capsule" fromto="0.004 -0.038 -0.03 0.0 -0.062 -0.085" '
                        'size="0.0115"', "skin"))
    return upper_geoms, fore_geoms, hand_geoms


def _person_body(spec: ClipSpec) -> str:
    """A person facing the camera (-y): legs with shoes, hips, a torso with shoulders,
    a neck, a head with eyes, brows, nose, mouth, ears and hair, the still right arm
    hanging, and the moving left arm (spatial, or the planar chain)."""
    look = _look(spec) or Appearance()
    b = look.build
    s = SHOULDER - np.array([0.0, 0.0, HIP_HEIGHT])
    if spec.spatial:
        arm = _spatial_arm(spec, s) + _torso_sites(s)
    else:
        chain, closing = _arm_chain(spec, s)
        arm = chain + closing
    still = _person_arm(look, HUMAN_SEGMENTS[0], HUMAN_SEGMENTS[1], moving=False,
                        prefix="still_")
    legs = "".join(
        f'<geom name="thigh_{side}" type="capsule" fromto="{x:.3f} 0 -0.02 {1.1 * x:.3f} 0 '
        f'-0.48" size="{0.075 * b:.4f}" material="pants"/>'
        f'<geom name="shin_{side}" type="capsule" fromto="{1.1 * x:.3f} 0 -0.48 {1.1 * x:.3f}'
        f' 0.01 -0.88" size="{0.052 * b:.4f}" material="pants"/>'
        f'<geom name="foot_{side}" type="box" pos="{1.1 * x:.3f} -0.05 -0.915" '
        f'size="0.045 0.115 0.035" material="shoes"/>'
        for side, x in (("l", 0.095), ("r", -0.095)))
    Vec = tuple[float, float, float]
    head: list[tuple[str, str, Vec, Vec, str]] = [
        ("hair", "ellipsoid", (0.0, 0.015, 0.04), (0.081, 0.089, 0.094), "hair")]
    if look.long_hair:
        head.append(("hair_long", "ellipsoid", (0.0, 0.035, -0.08), (0.095, 0.06, 0.16), "hair"))
    for side, x in (("l", 0.032), ("r", -0.032)):
        head += [(f"eye_{side}", "ellipsoid", (x, -0.079, 0.02), (0.015, 0.012, 0.009),
                  "eye_white"),
                 (f"pupil_{side}", "sphere", (x, -0.089, 0.02), (0.0065, 0.0, 0.0), "pupil"),
                 (f"brow_{side}", "box", (x, -0.085, 0.042), (0.017, 0.006, 0.0035), "hair"),
                 (f"ear_{side}", "ellipsoid", (2.35 * x, 0.0, 0.005), (0.012, 0.02, 0.03),
                  "skin_shade")]
    head += [("nose", "ellipsoid", (0.0, -0.095, -0.005), (0.012, 0.018, 0.022), "skin"),
             ("nostrils", "ellipsoid", (0.0, -0.1, -0.023), (0.011, 0.008, 0.004), "skin_shade"),
             ("mouth", "ellipsoid", (0.0, -0.083, -0.048), (0.024, 0.01, 0.0065), "lips")]
    face = "".join(  # positions from the head's centre
        f'<geom name="{name}" type="{kind}" pos="{fmt(np.add(pos, (0, 0, HEAD)))}" '
        f'size="{fmt(size[:1] if kind == "sphere" else size)}" material="{material}"/>'
        for name, kind, pos, size, material in head)
    return f"""
    <body name="root" pos="0 0 0">
      <joint name="sway_x" type="slide" axis="1 0 0"/>
      <body name="legs" pos="0 0 {HIP_HEIGHT}">{legs}</body>
      <body name="upper_body" pos="0 0 {HIP_HEIGHT}">
        <joint name="sway_roll" axis="0 -1 0"/>
        <geom name="hips" type="ellipsoid" pos="0 0 0.02" size="{0.165 * b:.4f} {0.105 * b:.4f} 0.12" material="pants"/>
        <geom name="belly" type="ellipsoid" pos="0 0 0.16" size="{0.145 * b:.4f} {0.095 * b:.4f} 0.2" material="shirt"/>
        <geom name="chest" type="ellipsoid" pos="0 -0.005 0.33" size="{0.17 * b:.4f} {0.1 * b:.4f} 0.15" material="shirt"/>
        <geom name="shoulders" type="capsule" fromto="-0.16 -0.01 0.43 0.16 -0.01 0.43" size="{0.055 * b:.4f}" material="shirt"/>
        <geom name="trapezius" type="ellipsoid" pos="0 0.01 0.45" size="{0.13 * b:.4f} {0.07 * b:.4f} 0.05" material="shirt"/>
        <geom name="neck" type="capsule" fromto="0 0.005 0.46 0 0.005 0.58" size="{0.048 * b:.4f}" material="skin"/>
        <geom name="head" type="ellipsoid" pos="0 0 {HEAD:.3f}" size="0.078 0.095 0.11" material="skin"/>
        {face}
        <body name="still_arm" pos="{fmt((-s[0], s[1], s[2]))}" euler="0 0.1 0">{still[0]}
          <body name="still_forearm" pos="0 0 {-HUMAN_SEGMENTS[0]}" euler="-0.15 0 0">{still[1]}
            <body name="still_hand" pos="0 0 {-HUMAN_SEGMENTS[1]}">{still[2]}</body>
          </body>
        </body>
        {arm}
      </body>
    </body>"""


def _servo_body(spec: ClipSpec) -> str:
    """The paper's servo arm seen from above: servo case, horn and paper links."""
    chain, closing = "", ""
    for i, length in enumerate(spec.link_lengths):
        pos = "0 0 0.024" if i == 0 else fmt((spec.link_lengths[i - 1], 0, 0.004))
        quat = f'quat="{fmt(link_frame_quat("horizontal", spec.reference_direction))}"' if i == 0 else ""
        lo, hi = spec.joint_ranges[i]
        keypoint = "pivot" if i == 0 else f"joint{i + 1}"
        chain += (
            f'<body name="link{i + 1}" pos="{pos}" {quat}>'
            f'<joint name="q{i + 1}" axis="0 0 1" range="{lo:.12g} {hi:.12g}"/>'
            f'<site name="kp_{keypoint}" size="0.003"/>'
            f'<geom name="horn{i + 1}" type="cylinder" size="0.008 0.002" material="servo" '
            f'group="{MOVING_GROUP}"/>'
            f'<geom name="link{i + 1}" type="box" pos="{length / 2} 0 0.002" '
            f'size="{length / 2 + 0.006} 0.0075 0.001" material="paper" group="{MOVING_GROUP}"/>'
        )
        closing += "</body>"
    chain += f'<site name="kp_tip" pos="{spec.link_lengths[-1]} 0 0" size="0.003"/>'
    return f"""
    <body name="root" pos="0 0 0">
      <joint name="sway_x" type="slide" axis="1 0 0"/>
      <inertial pos="0 0 0" mass="0.1" diaginertia="1e-4 1e-4 1e-4"/>
      <body name="upper_body">
        <joint name="sway_roll" axis="0 0 1"/>
        <geom name="servo_case" type="box" pos="0.005 0 0.011" size="0.0115 0.0062 0.011" material="servo"/>
        {chain}{closing}
      </body>
    </body>"""


def _clutter(spec: ClipSpec, rng: np.random.Generator) -> str:
    if spec.background != "cluttered":
        return ""
    shapes = []
    for i in range(7 if spec.appearance is None else spec.appearance.clutter):
        colour = fmt((*rng.uniform(0.15, 0.95, 3), 1.0))
        if spec.demonstrator != "servo":
            pos = (rng.uniform(-1.4, 1.6), 0.58, rng.uniform(0.4, 2.3))
            size = (rng.uniform(0.06, 0.2), 0.01, rng.uniform(0.06, 0.2))
        else:
            pos = (rng.uniform(-0.15, 0.15), rng.uniform(-0.1, 0.2), 0.0005)
            size = (rng.uniform(0.008, 0.025), rng.uniform(0.008, 0.025), 0.0005)
        shapes.append(
            f'<geom name="clutter{i}" type="box" pos="{fmt(pos)}" size="{fmt(size)}" rgba="{colour}"/>'
        )
    return "\n    ".join(shapes)


def camera_pose(spec: ClipSpec) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """The film camera of a person's scene: position (3,) m, its image-right and image-up
    axes (3,) (unit, world frame) and its vertical field of view in degrees."""
    if spec.demonstrator == "servo":
        raise ValueError("camera_pose places the camera of a person's scene, not the servo's")
    if spec.spatial:  # the person from the thighs up, room for the arm raised
        look = np.array([0.2, 0.0, 1.4])
    elif spec.demonstrator == "human":  # the person's arm in the middle
        look = np.array([0.3, 0.0, 1.35])
    else:  # the hand, filmed closer: its workspace in the middle
        centre, _ = workspace(spec)
        look = np.array([centre[0], 0.0, centre[2]])
    position = look - (0, spec.camera_distance, 0)
    appearance = spec.appearance
    if appearance is None:
        return position, np.array([1.0, 0.0, 0.0]), np.array([0.0, 0.0, 1.0]), 45.0
    tilt = math.radians(appearance.camera_tilt)
    position = position + np.array([appearance.camera_shift, 0.0, appearance.camera_height])
    up = np.array([0.0, math.sin(tilt), math.cos(tilt)])  # pitched down by the tilt
    return position, np.array([1.0, 0.0, 0.0]), up, appearance.fovy


def _camera(spec: ClipSpec) -> str:
    position, right, up, fovy = camera_pose(spec)
    if spec.appearance is None:  # the text every named scenario's scene has always had
        return (f'<camera name="film" pos="{fmt(position)}" xyaxes="1 0 0 0 0 1" '
                f'fovy="45"/>')
    return (f'<camera name="film" pos="{fmt(position)}" xyaxes="{fmt((*right, *up))}" '
            f'fovy="{fovy:.12g}"/>')


def _key_light(spec: ClipSpec) -> str:
    """The directional key light of a person's scene."""
    light = spec.lighting
    if spec.appearance is None:
        direction, tint = "-0.25 0.75 -1", np.ones(3)
    else:
        direction, tint = fmt(spec.appearance.light_direction), np.array(
            spec.appearance.light_colour)
    return (f'<light name="key" directional="true" pos="1 -3 4" dir="{direction}" '
            f'diffuse="{fmt(0.7 * light * tint)}" ambient="{fmt(0.2 * light * tint)}" '
            'specular="0.1 0.1 0.1" castshadow="false"/>')


def scene_mjcf(spec: ClipSpec, rng: np.random.Generator) -> str:
    """MJCF of the whole scene for ``spec``. ``rng`` places the clutter."""
    centre, radius = workspace(spec)
    light = spec.lighting
    if spec.demonstrator != "servo":
        camera = _camera(spec)
        backdrop = (
            '<geom name="wall" type="box" pos="0 0.6 1.5" size="6 0.005 4" material="wall"/>\n'
            '    <geom name="floor" type="box" pos="0 0 -0.005" size="6 6 0.005" material="floor"/>'
        )
        body = _person_body(spec) if spec.body == "person" else _human_body(spec)
        board_offset, board_axis = np.array([0, -0.5, 0]), "xz"
        distractor_size = 0.08
        light_el = _key_light(spec)
    else:
        look = np.array([0.0, 0.05, 0.0])
        camera = f'<camera name="film" pos="{fmt((look[0], look[1], spec.camera_distance))}" xyaxes="1 0 0 0 1 0" fovy="45"/>'
        backdrop = '<geom name="table" type="box" pos="0 0 -0.005" size="2 2 0.005" material="table"/>'
        body = _servo_body(spec)
        board_offset, board_axis = np.array([0, 0, 0.1]), "xy"
        distractor_size = 0.012
        light_el = f'<light name="key" directional="true" pos="0.2 -0.3 1" dir="-0.2 0.3 -1" diffuse="{fmt((0.7 * light,) * 3)}" ambient="{fmt((0.2 * light,) * 3)}" specular="0.1 0.1 0.1" castshadow="false"/>'
    half_width = {"none": 0.0, "low": 0.08, "high": 0.3}[spec.occluder] * radius
    half_height = 0.75 * radius
    board_size = (half_width, 0.004, half_height) if board_axis == "xz" else (half_width, half_height, 0.002)
    occluder = ""
    if spec.occluder != "none":
        occluder = (
            f'<body name="occluder" mocap="true" pos="{fmt(centre + board_offset)}">'
            f'<geom name="occluder" type="box" size="{fmt(board_size)}" material="board" '
            f'/></body>'
        )
    distractor = ""
    if spec.background == "cluttered":
        behind = np.array([0, 0.35, 0]) if spec.demonstrator != "servo" else np.array([0, 0, distractor_size - 0.024])
        distractor = (
            f'<body name="distractor" mocap="true" pos="{fmt(centre + behind)}">'
            f'<geom name="distractor" type="sphere" size="{distractor_size}" material="distractor"/></body>'
        )
    return f"""<mujoco model="imimic_demonstrator">
  <compiler angle="radian"/>
  <visual>
    <quality shadowsize="0" offsamples="0" numslices="16" numstacks="8" numquads="1"/>
    <global offwidth="{spec.width}" offheight="{spec.height}"/>
    <headlight ambient="{fmt((0.25 * light,) * 3)}" diffuse="{fmt((0.35 * light,) * 3)}" specular="0 0 0"/>
    <map znear="0.01"/>
  </visual>
  <asset>{_materials(_look(spec))}{
      _person_materials(_look(spec) or Appearance()) if spec.body == "person" else ""}
  </asset>
  <worldbody>
    {light_el}
    {camera}
    {backdrop}
    {_tiles(spec)}
    {_clutter(spec, rng)}
    {body}
    {occluder}
    {distractor}
  </worldbody>
</mujoco>
"""


def occluder_path(spec: ClipSpec, t: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """(T, 3) board centre offsets (m): sweeps across the arm, along the image's x axis."""
    _, radius = workspace(spec)
    period = rng.uniform(2.5, 3.5)
    phase = rng.uniform(0, 2 * math.pi)
    offsets = np.zeros((t.size, 3))
    offsets[:, 0] = 1.1 * radius * np.sin(2 * math.pi * t / period + phase)
    return offsets


def distractor_path(spec: ClipSpec, t: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """(T, 3) offsets (m) of the distractor ball: a Lissajous loop over the background."""
    _, radius = workspace(spec)
    periods = rng.uniform(1.6, 2.6, size=2)
    phases = rng.uniform(0, 2 * math.pi, size=2)
    a = 1.5 * radius * np.sin(2 * math.pi * t / periods[0] + phases[0])
    b = 0.8 * radius * np.sin(2 * math.pi * t / periods[1] + phases[1])
    offsets = np.zeros((t.size, 3))
    offsets[:, 0] = a
    offsets[:, 2 if spec.demonstrator != "servo" else 1] = b
    return offsets
