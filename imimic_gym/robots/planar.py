"""The robot arm: a planar serial chain of 1 to 3 revolute links, generated as MJCF.

Geometry convention (shared with the demonstrator clips, see DESIGN.md):
- The arm moves in a plane that the camera sees face-on. Directions in that plane are
  angles in radians measured counter-clockwise, as seen by the camera, from the image's
  right-pointing axis.
- ``reference_direction`` is the direction of the fixed reference link (the torso's
  downward axis for a shoulder, the upper arm for a forearm, the servo's zero mark).
  Joint ``q_1`` is link 1's angle relative to it, ``q_i`` link i's angle relative to
  link i-1; counter-clockwise is positive.
- ``plane="vertical"`` is the x-z plane (a standing person's arm, gravity acts in the
  plane); ``plane="horizontal"`` is the x-y plane (the paper's servo filmed from above,
  gravity along the joint axes).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import mujoco
import numpy as np

__all__ = [
    "CONTROL_MODES", "ArmSpec", "Control", "Plane", "arm_mjcf", "build_arm_model",
    "joint_inertia", "link_frame_quat", "plane_axes",
]

Control = Literal["position", "velocity", "torque"]
Plane = Literal["vertical", "horizontal"]
CONTROL_MODES: tuple[str, ...] = ("position", "velocity", "torque")
MAX_LINKS = 3


@dataclass(frozen=True)
class ArmSpec:
    """Everything that defines a robot arm. Lengths in metres, masses in kg, angles in rad.

    ``servo_bandwidth_hz`` sets the position servo's stiffness per joint from the arm's
    own inertia (kp = I * (2 pi f)^2, critically damped), so a light paper link and a
    human-sized arm respond equally fast without hand-tuned gains.

    ``max_torque`` (N m) is the base joint's motor limit; the others follow from it
    (`torque_limits`).
    """

    link_lengths: tuple[float, ...] = (0.27,)
    link_masses: tuple[float, ...] = (0.6,)
    joint_ranges: tuple[tuple[float, float], ...] = ((-math.pi / 3, math.pi / 3),)
    joint_damping: float = 0.05
    plane: Plane = "vertical"
    reference_direction: float = 0.0
    reference_length: float = 0.0
    control: Control = "position"
    servo_bandwidth_hz: float = 12.0
    max_velocity: float = 2 * math.pi
    max_torque: float = 20.0
    link_radius: float = 0.025
    timestep: float = 0.002
    rgba: tuple[float, float, float, float] = (0.95, 0.55, 0.1, 1.0)
    parents: tuple[int, ...] | None = None

    def __post_init__(self) -> None:
        n = len(self.link_lengths)
        if not 1 <= n <= MAX_LINKS:
            raise ValueError(f"an arm has 1 to {MAX_LINKS} links, got {n} link lengths")
        if len(self.link_masses) != n or len(self.joint_ranges) != n:
            raise ValueError(
                f"link_lengths, link_masses and joint_ranges must have one entry per link; "
                f"got {n}, {len(self.link_masses)}, {len(self.joint_ranges)}"
            )
        if any(length <= 0 for length in self.link_lengths):
            raise ValueError(f"link lengths must be positive metres, got {self.link_lengths}")
        if any(m <= 0 for m in self.link_masses):
            raise ValueError(f"link masses must be positive kg, got {self.link_masses}")
        for lo, hi in self.joint_ranges:
            if not lo < hi:
                raise ValueError(f"a joint range must have low < high, got ({lo}, {hi})")
        if self.control not in CONTROL_MODES:
            raise ValueError(f"control must be one of {CONTROL_MODES}, got {self.control!r}")
        if self.plane not in ("vertical", "horizontal"):
            raise ValueError(f"plane must be 'vertical' or 'horizontal', got {self.plane!r}")
        parents = self.link_parents
        if len(parents) != n or parents[0] != -1 or any(
            not 0 <= p < i for i, p in enumerate(parents[1:], start=1)
        ):
            raise ValueError(
                f"parents must give link 0 the base (-1) and every later link an earlier "
                f"link, one entry per link; got {self.parents}"
            )

    name = "planar"

    @property
    def n_links(self) -> int:
        return len(self.link_lengths)

    @property
    def n_joints(self) -> int:
        """One joint per link (`robots.spec.RobotSpec`)."""
        return len(self.link_lengths)

    @property
    def joint_names(self) -> tuple[str, ...]:
        """The MJCF joints' names: q1, q2, ..."""
        return tuple(f"q{i + 1}" for i in range(self.n_links))

    def build_model(self) -> mujoco.MjModel:
        """`build_arm_model` of this spec."""
        return build_arm_model(self)

    @property
    def link_parents(self) -> tuple[int, ...]:
        """Each link's parent link (-1: the base). A chain unless ``parents`` says
        otherwise (the hand: thumb and index finger both on the forearm)."""
        return self.parents if self.parents is not None else tuple(range(-1, self.n_links - 1))

    @property
    def reach(self) -> float:
        """Longest distance from the base joint to a tip with the arm straight, metres."""
        parents = self.link_parents
        total: list[float] = []
        for i, length in enumerate(self.link_lengths):
            total.append(length + (total[parents[i]] if parents[i] >= 0 else 0.0))
        return float(max(total))

    @property
    def torque_limits(self) -> tuple[float, ...]:
        """Each joint's motor limit (N m). In the vertical plane every joint can hold its
        own static load (the links it carries, held straight out against gravity) the
        same number of times over as the base joint's ``max_torque`` holds the base's;
        in the horizontal plane gravity loads no joint, and all share ``max_torque``.

        One limit for all joints let a light link reach accelerations no integrator
        step can follow: the hand's 50 g fingers under 25 N m flipped sign every frame
        drove MuJoCo unstable within five frames, and the `chain-3` wrist went 45
        degrees past its joint limit."""
        if self.plane == "horizontal":
            return (self.max_torque,) * self.n_links
        parents, n = self.link_parents, self.n_links

        def moment(joint: int) -> float:
            """Sum of mass * lever arm (kg m) over the links ``joint`` carries, the arm held
            straight: its static load over g, and g cancels in the ratios below."""
            total, stack = 0.0, [(joint, 0.0)]
            while stack:
                link, start = stack.pop()
                total += self.link_masses[link] * (start + self.link_lengths[link] / 2)
                end = start + self.link_lengths[link]
                stack.extend((c, end) for c in range(n) if parents[c] == link)
            return total

        per_moment = self.max_torque / moment(0)
        return tuple(self.max_torque if i == 0 else per_moment * moment(i) for i in range(n))


def plane_axes(plane: Plane) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(image-right axis, image-up axis, joint axis) in world coordinates.

    The joint axis points toward the camera, so that a positive joint angle turns
    counter-clockwise as the camera sees it.
    """
    if plane == "vertical":
        return np.array([1.0, 0, 0]), np.array([0, 0, 1.0]), np.array([0, -1.0, 0])
    return np.array([1.0, 0, 0]), np.array([0, 1.0, 0]), np.array([0, 0, 1.0])


def link_frame_quat(plane: Plane, direction: float) -> np.ndarray:
    """Quaternion of a link frame whose x axis points along ``direction`` (rad, in the
    image plane) and whose z axis is the joint axis, so a hinge ``axis="0 0 1"`` turns
    counter-clockwise as the camera sees it."""
    right, up, axis = plane_axes(plane)
    x = math.cos(direction) * right + math.sin(direction) * up
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, np.column_stack([x, np.cross(axis, x), axis]).flatten())
    return quat


def fmt(v: np.ndarray | tuple[float, ...]) -> str:
    return " ".join(f"{float(x):.12g}" for x in v)


def arm_mjcf(spec: ArmSpec) -> str:
    """The MJCF text of the arm, its camera (named ``robot``) and lights, for ``spec``."""
    right, up, axis = plane_axes(spec.plane)
    direction = math.cos(spec.reference_direction) * right + math.sin(
        spec.reference_direction
    ) * up
    base = np.zeros(3) if spec.plane == "horizontal" else np.array([0.0, 0.0, 1.0])
    # Frame the whole workspace: reach circle plus the drawn reference link.
    span = 2.4 * (spec.reach + 0.5 * spec.reference_length) + 0.1
    cam_dist = span / (2 * math.tan(math.radians(45) / 2))
    toward_camera = axis
    cam_pos = base + cam_dist * toward_camera
    r = spec.link_radius

    parents = spec.link_parents

    def body(i: int, depth: int) -> str:
        """Link i's body with its joint and geoms, its child links nested inside."""
        pad = "  " * depth
        lo, hi = spec.joint_ranges[i]
        if parents[i] < 0:
            pos = fmt(base)
            orient = f'quat="{fmt(link_frame_quat(spec.plane, spec.reference_direction))}"'
        else:
            pos, orient = fmt((spec.link_lengths[parents[i]], 0, 0)), ""
        children = "".join(body(j, depth + 1) for j in range(spec.n_links) if parents[j] == i)
        return (
            f'{pad}<body name="link{i + 1}" pos="{pos}" {orient}>\n'
            f'{pad}  <joint name="q{i + 1}" type="hinge" axis="0 0 1" '
            f'range="{lo:.12g} {hi:.12g}" limited="true" damping="{spec.joint_damping}"/>\n'
            f'{pad}  <geom name="link{i + 1}" type="capsule" '
            f'fromto="0 0 0 {spec.link_lengths[i]:.12g} 0 0" size="{r:.4g}" '
            f'mass="{spec.link_masses[i]:.12g}" material="arm"/>\n'
            f'{pad}  <geom name="joint{i + 1}" type="cylinder" '
            f'fromto="0 0 {-1.4 * r:.4g} 0 0 {1.4 * r:.4g}" size="{1.5 * r:.4g}" '
            f'mass="0" contype="0" conaffinity="0" material="joint"/>\n'
            f"{children}{pad}</body>\n"
        )

    chain = body(0, 2)

    ref_geom = ""
    if spec.reference_length > 0:
        ref_end = base - spec.reference_length * direction
        ref_geom = (
            f'    <geom name="reference_link" type="capsule" fromto="{fmt(ref_end)} '
            f'{fmt(base)}" size="{1.1 * r:.4g}" material="reference" contype="0" '
            f'conaffinity="0"/>\n'
        )

    actuators = []
    torque_limits = spec.torque_limits
    for i, (lo, hi) in enumerate(spec.joint_ranges):
        name = f'name="a{i + 1}" joint="q{i + 1}"'
        if spec.control == "position":
            # Gains are placeholders: build_arm_model sets them from the arm's inertia.
            actuators.append(
                f'    <position {name} kp="1" kv="0.1" ctrlrange="{lo:.12g} {hi:.12g}"/>'
            )
        elif spec.control == "velocity":
            actuators.append(
                f'    <velocity {name} kv="1" ctrlrange="{-spec.max_velocity:.12g} '
                f'{spec.max_velocity:.12g}"/>'
            )
        else:
            actuators.append(
                f'    <motor {name} gear="1" ctrlrange="{-torque_limits[i]:.12g} '
                f'{torque_limits[i]:.12g}"/>'
            )
    up_vec = up if spec.plane == "vertical" else np.array([0.0, 1.0, 0.0])
    light_pos = base + 3 * cam_dist * toward_camera + up_vec
    return f"""<mujoco model="imimic_arm">
  <compiler angle="radian"/>
  <option timestep="{spec.timestep:.12g}" gravity="0 0 -9.81" integrator="implicitfast"/>
  <visual>
    <quality shadowsize="0" offsamples="0"/>
    <global offwidth="1280" offheight="960"/>
    <headlight ambient="0.35 0.35 0.35" diffuse="0.5 0.5 0.5"/>
  </visual>
  <asset>
    <material name="arm" rgba="{fmt(spec.rgba)}" specular="0.3"/>
    <material name="joint" rgba="0.15 0.15 0.18 1"/>
    <material name="reference" rgba="0.55 0.55 0.6 1"/>
    <material name="backdrop" rgba="0.93 0.93 0.95 1"/>
  </asset>
  <worldbody>
    <light pos="{fmt(light_pos)}" dir="{fmt(-toward_camera)}" castshadow="false"/>
    <camera name="robot" pos="{fmt(cam_pos)}" xyaxes="{fmt(right)} {fmt(up)}" fovy="45"/>
    <!-- A thin box, not a plane: the software renderer draws planes as many lit quads. -->
    <geom name="backdrop" type="box" pos="{fmt(base - 0.3 * axis)}"
          zaxis="{fmt(toward_camera)}" size="5 5 0.005" material="backdrop"
          contype="0" conaffinity="0"/>
{ref_geom}{chain}  </worldbody>
  <actuator>
{chr(10).join(actuators)}
  </actuator>
</mujoco>
"""


def joint_inertia(model: mujoco.MjModel) -> np.ndarray:
    """(n,) kg m^2: each joint's effective inertia with the arm straight (the diagonal of
    the joint-space mass matrix at qpos0), the scale for servo and controller gains."""
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    mass_matrix = np.zeros((model.nv, model.nv))
    mujoco.mj_fullM(model, data, mass_matrix)
    return np.diag(mass_matrix) + model.dof_armature


def build_arm_model(spec: ArmSpec) -> mujoco.MjModel:
    """Compile ``spec`` into an ``MjModel``, with servo gains set from the arm's inertia.

    Links do not collide with each other (planar arm: its links overlap at the joints).
    """
    model = mujoco.MjModel.from_xml_string(arm_mjcf(spec))
    model.geom_contype[:] = 0
    model.geom_conaffinity[:] = 0
    inertia = joint_inertia(model)
    omega = 2 * math.pi * spec.servo_bandwidth_hz
    if spec.control == "position":
        kp = inertia * omega**2
        kv = 2 * inertia * omega  # critically damped
        model.actuator_gainprm[:, 0] = kp
        model.actuator_biasprm[:, 1] = -kp
        model.actuator_biasprm[:, 2] = -kv
    elif spec.control == "velocity":
        kv = 2 * inertia * omega
        model.actuator_gainprm[:, 0] = kv
        model.actuator_biasprm[:, 2] = -kv
    return model
