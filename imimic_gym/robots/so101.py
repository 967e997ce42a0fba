"""The SO-101 arm (TheRobotStudio / Hugging Face, six STS3215 servos) as a MuJoCo model of
primitive geoms, with LeRobot's joint names, ranges and zero.

Frames and units:
- **Robot base frame** (MuJoCo world of this model): metres, x forward (the way the arm
  reaches at pan 0), y to the robot's left, z up; the base's underside at z = 0.
- Joint values: rad, 0 at the middle of each joint's calibrated range, which is LeRobot's
  degree 0 ("new calibration"); sim qpos (rad) = radians(LeRobot degrees) for the five
  body joints. The gripper's LeRobot value is 0-100 over its joint range (0 closed).
- Sign conventions (from the official model): shoulder_pan turns about -z (positive pans
  toward -y); shoulder_lift, elbow_flex and wrist_flex turn about the arm plane's normal so
  that positive values tip the links forward and down; at all-zero the upper arm stands
  14 degrees forward of vertical, the forearm and the wrist point straight forward.

The kinematic facts (body offsets, axes, ranges, masses) come from the official model; see
docs/decisions/so101-model.md for sources and the zero convention.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import mujoco
import numpy as np

__all__ = ["GRIPPER_RANGE", "JOINT_NAMES", "JOINT_RANGES", "SO101Spec"]

JOINT_NAMES: tuple[str, ...] = (
    "shoulder_pan", "shoulder_lift", "elbow_flex", "wrist_flex", "wrist_roll", "gripper",
)
# rad, as in the official model (so101_new_calib): symmetric about LeRobot's zero.
JOINT_RANGES: tuple[tuple[float, float], ...] = (
    (-1.91986, 1.91986),   # shoulder_pan, +-110 deg
    (-1.74533, 1.74533),   # shoulder_lift, +-100 deg
    (-1.69, 1.69),         # elbow_flex, +-96.8 deg
    (-1.65806, 1.65806),   # wrist_flex, +-95 deg
    (-2.74385, 2.74385),   # wrist_roll, +-157.2 deg
    (-0.174533, 1.745329),  # gripper, -10 (closed, squeezing) to 100 deg (open)
)
GRIPPER_RANGE = JOINT_RANGES[5]
_BODY_JOINTS = 5

_YELLOW = "1 0.82 0.12 1"
_SERVO = "0.1 0.1 0.1 1"

# One MJCF template; {kp}, {kv}, ... are filled from the spec. Body offsets and
# orientations are the official model's; the geoms are simple stand-ins for its meshes.
_MJCF = """<mujoco model="so101">
  <compiler angle="radian" autolimits="true"/>
  <option timestep="{timestep}" integrator="implicitfast"/>
  <visual>
    <global offwidth="640" offheight="480"/>
    <quality shadowsize="0" offsamples="0"/>
    <headlight ambient="0.35 0.35 0.35" diffuse="0.5 0.5 0.5"/>
  </visual>
  <default>
    <geom contype="0" conaffinity="0" rgba="{yellow}"/>
    <joint damping="{damping}" armature="{armature}" frictionloss="{frictionloss}"/>
    <position kp="{kp}" kv="{kv}" forcerange="-{max_torque} {max_torque}"/>
    <default class="servo"><geom type="box" size="0.012 0.0225 0.0175" rgba="{servo}"/></default>
  </default>
  <worldbody>
    <light pos="0.3 0.4 1.2" dir="-0.2 -0.3 -1"/>
    <!-- Thin boxes, not planes: the software renderer draws planes as many lit quads. -->
    <geom name="floor" type="box" pos="0 0 -0.005" size="1.5 1.5 0.005" rgba="0.62 0.6 0.58 1"/>
    <geom name="backdrop" type="box" pos="-0.35 0 0.5" size="0.005 1.5 0.6" rgba="0.78 0.8 0.84 1"/>
    <!-- In front of the robot, facing it: the robot's left is the picture's right, as a
         person facing the camera shows their left arm on the right (the mirror mapping). -->
    <camera name="robot" pos="0.95 0 0.36" xyaxes="0 1 0 -0.165 0 0.986" fovy="52"/>
    <body name="base">
      <inertial pos="0.0137 0 0.0335" mass="0.147" diaginertia="1.1e-4 1.4e-4 1.3e-4"/>
      <geom type="box" pos="0.02 0 0.024" size="0.05 0.045 0.024"/>
      <geom class="servo" pos="0.0263 0 0.044" euler="0 0 1.5708"/>
      <body name="shoulder_link" pos="0.0388353 0 0.0624" quat="0 0 -1 0">
        <joint name="shoulder_pan" axis="0 0 1" range="{r0}"/>
        <inertial pos="-0.0308 0 -0.0253" mass="0.100" diaginertia="8.4e-5 8.1e-5 2.4e-5"/>
        <geom type="capsule" size="0.016" fromto="0 0 0 -0.0304 -0.0183 -0.0542"/>
        <body name="upper_arm" pos="-0.0303992 -0.0182778 -0.0542" quat="1 -1 -1 -1">
          <joint name="shoulder_lift" axis="0 0 1" range="{r1}"/>
          <inertial pos="-0.0898 -0.0084 0.0184" mass="0.103" diaginertia="4.1e-5 1.47e-4 1.42e-4"/>
          <site name="shoulder" size="0.006"/>
          <geom class="servo" pos="0 0 0.0187"/>
          <geom type="capsule" size="0.014" fromto="0 0 0.0182 -0.11257 -0.028 0.0182"/>
          <body name="lower_arm" pos="-0.11257 -0.028 0" quat="1 0 0 1">
            <joint name="elbow_flex" axis="0 0 1" range="{r2}"/>
            <inertial pos="-0.0981 0.0032 0.0183" mass="0.104" diaginertia="2.9e-5 1.6e-4 1.45e-4"/>
            <site name="elbow" size="0.006"/>
            <geom class="servo" pos="0 0 0.0187"/>
            <geom type="capsule" size="0.013" fromto="0 0 0.0182 -0.1349 0.0052 0.0182"/>
            <body name="wrist_link" pos="-0.1349 0.0052 0" quat="1 0 0 -1">
              <joint name="wrist_flex" axis="0 0 1" range="{r3}"/>
              <inertial pos="-0.0001 -0.0386 0.0281" mass="0.079" diaginertia="3.7e-5 2.5e-5 2.1e-5"/>
              <site name="wrist" size="0.006"/>
              <geom class="servo" pos="0 -0.0424 0.0256" euler="0 0 1.5708"/>
              <body name="gripper_link" pos="0 -0.0611 0.0181" quat="0.0172091 -0.0172091 0.706897 0.706897">
                <joint name="wrist_roll" axis="0 0 1" range="{r4}"/>
                <inertial pos="0.0002 0.0002 -0.0252" mass="0.087" diaginertia="2.8e-5 4.3e-5 3.5e-5"/>
                <site name="tool" pos="0.012 -0.000218 -0.098127" size="0.006"/>
                <geom class="servo" pos="0.0077 0 -0.0234" euler="1.5708 0 0"/>
                <geom type="box" pos="-0.011 0 -0.06" size="0.004 0.012 0.04"/>
                <body name="moving_jaw" pos="0.0202 0.0188 -0.0234" quat="1 1 0 0">
                  <joint name="gripper" axis="0 0 1" range="{r5}"/>
                  <inertial pos="-0.0016 -0.030 0.0193" mass="0.012" diaginertia="6.6e-6 1.9e-6 5.3e-6"/>
                  <geom type="capsule" size="0.005" fromto="0 -0.01 0.019 -0.012 -0.074 0.019"/>
                </body>
              </body>
            </body>
          </body>
        </body>
      </body>
    </body>
  </worldbody>
  <actuator>
{actuators}
  </actuator>
</mujoco>
"""


@dataclass(frozen=True)
class SO101Spec:
    """The SO-101 robot description (module docstring: frames, units, zero).

    Attributes:
        name: "so101".
        joint_names: LeRobot's motor names, in qpos and actuator order.
        joint_ranges: (low, high) rad per joint.
        shoulder_site, elbow_site, wrist_site, tool_site: MuJoCo site names on the
            shoulder_lift axis, the elbow_flex axis, the wrist_flex axis and the gripper's tip.
        kp: position servo stiffness, N m / rad; kv: its damping, N m s / rad.
        max_torque: N m, each servo's torque limit (the STS3215's stall torque).
        damping, armature, frictionloss: per joint (N m s / rad, kg m^2, N m).
        timestep: s.
    """

    name: str = "so101"
    joint_names: tuple[str, ...] = JOINT_NAMES
    joint_ranges: tuple[tuple[float, float], ...] = JOINT_RANGES
    shoulder_site: str = "shoulder"
    elbow_site: str = "elbow"
    wrist_site: str = "wrist"
    tool_site: str = "tool"
    kp: float = 50.0
    kv: float = 2.0
    max_torque: float = 2.94
    damping: float = 0.6
    armature: float = 0.028
    frictionloss: float = 0.052
    timestep: float = 0.002

    @property
    def site_names(self) -> tuple[str, str, str, str]:
        """(shoulder, elbow, wrist, tool) site names."""
        return (self.shoulder_site, self.elbow_site, self.wrist_site, self.tool_site)

    @property
    def lower(self) -> np.ndarray:
        """(6,) rad, each joint's lower limit."""
        return np.array([lo for lo, _ in self.joint_ranges])

    @property
    def upper(self) -> np.ndarray:
        """(6,) rad, each joint's upper limit."""
        return np.array([hi for _, hi in self.joint_ranges])

    def mjcf(self) -> str:
        """The model as an MJCF string: no asset files, primitive geoms only, one position
        actuator per joint named as its joint, ctrl in rad."""
        ranges = {f"r{i}": f"{lo} {hi}" for i, (lo, hi) in enumerate(self.joint_ranges)}
        actuators = "\n".join(
            f'    <position name="{name}" joint="{name}" ctrlrange="{lo} {hi}"/>'
            for name, (lo, hi) in zip(self.joint_names, self.joint_ranges, strict=True))
        return _MJCF.format(
            timestep=self.timestep, kp=self.kp, kv=self.kv, max_torque=self.max_torque,
            damping=self.damping, armature=self.armature, frictionloss=self.frictionloss,
            yellow=_YELLOW, servo=_SERVO, actuators=actuators, **ranges)

    def build_model(self) -> mujoco.MjModel:
        """A fresh compiled model of `mjcf`."""
        return mujoco.MjModel.from_xml_string(self.mjcf())

    @cached_property
    def _fk(self) -> tuple[mujoco.MjModel, mujoco.MjData]:
        model = self.build_model()
        return model, mujoco.MjData(model)

    def forward_kinematics(self, q: np.ndarray) -> dict[str, np.ndarray]:
        """Site positions at joint values ``q`` (6,) rad: {site name: (3,) metres, robot
        base frame} for the shoulder, elbow, wrist and tool sites."""
        q = np.asarray(q, dtype=np.float64)
        if q.shape != (len(self.joint_names),):
            raise ValueError(f"q must have shape ({len(self.joint_names)},), got {q.shape}")
        model, data = self._fk
        data.qpos[:] = q
        mujoco.mj_kinematics(model, data)
        return {name: data.site(name).xpos.copy() for name in self.site_names}

    def to_lerobot(self, q_rad: np.ndarray) -> dict[str, float]:
        """Joint values (6,) rad -> LeRobot's user units by motor name: degrees for the five
        body joints (LeRobot's ``use_degrees=True``), 0-100 over the gripper's range. No
        clipping."""
        q = np.asarray(q_rad, dtype=np.float64)
        if q.shape != (len(self.joint_names),):
            raise ValueError(f"q_rad must have shape ({len(self.joint_names)},), got {q.shape}")
        values = {name: math.degrees(float(v))
                  for name, v in zip(self.joint_names[:_BODY_JOINTS], q[:_BODY_JOINTS],
                                     strict=True)}
        lo, hi = self.joint_ranges[_BODY_JOINTS]
        values[self.joint_names[_BODY_JOINTS]] = 100.0 * (float(q[_BODY_JOINTS]) - lo) / (hi - lo)
        return values

    def from_lerobot(self, values: dict[str, float]) -> np.ndarray:
        """LeRobot's user units by motor name (as `to_lerobot`) -> (6,) rad. No clipping."""
        missing = [name for name in self.joint_names if name not in values]
        if missing:
            raise KeyError(f"LeRobot values lack joints {missing}; got {sorted(values)}")
        q = np.array([math.radians(values[name]) for name in self.joint_names[:_BODY_JOINTS]]
                     + [0.0])
        lo, hi = self.joint_ranges[_BODY_JOINTS]
        q[_BODY_JOINTS] = lo + values[self.joint_names[_BODY_JOINTS]] / 100.0 * (hi - lo)
        return q

    # What every robot description says (`robots.spec.RobotSpec`): STS3215s are position
    # servos, and the joints form one chain.
    control = "position"

    @property
    def n_joints(self) -> int:
        return len(self.joint_names)

    @property
    def link_parents(self) -> tuple[int, ...]:
        return tuple(range(-1, len(self.joint_names) - 1))

    def clip(self, q: np.ndarray) -> np.ndarray:
        """``q`` (6,) rad clipped into the joint ranges."""
        return np.clip(np.asarray(q, dtype=np.float64), self.lower, self.upper)
