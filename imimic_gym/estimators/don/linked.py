"""DON for a tree of 2-3 links (`LinkedDON`): the paper's object regression layer (§3,
"a line per link") on top of DON's layers 1-3 (`motion_mask.MotionMask`).

In: (H, W, 3) uint8 RGB frames, one at a time (`LinkedDON.update`). Out: per frame an
`Estimate` with n joints: angles (n,) rad, each link from its parent (the root from the
reference direction), CCW in the image; omega (n,) rad/s and alpha (n,) rad/s^2 from the
path estimator (paper Eqs. V, A); torque (n,) N m, the robot model's inverse dynamics
(``mj_inverse``, so coupling and gravity count), else 0; eta per paper Eq. (TF) with M_p
the area of l_p, as the paper has it; ``predicted`` always False (no several-link
occlusion scenario exists to tune a prediction layer on); keypoints (n + 1, 2) input px,
the root pivot and each link's tip, once known.

The links are fitted together to l_1 (`chain_fit.Chain`); the root pivot is found where
the moving tree's far ends recur (`chain_fit.facing_point`), each link's length is the
median of measured corners; l_1 spans frames t-1 and t, so the angles reported are the
fit's q + omega / (2 fps). The appearance layer (ours, `appearance.py`) then reads each
long enough link's direction from its colour. Every knob is a field of
`LinkedDONConfig`; why each rule: `docs/decisions/linked-don.md`.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Iterable, Sequence
from typing import Any

import cv2
import mujoco
import numpy as np

from imimic_gym.estimators.don.appearance import LinkAppearance
from imimic_gym.estimators.don.chain_fit import Chain, blob_ends, corner, direction_of, facing_point
from imimic_gym.estimators.don.config import LinkedDONConfig, override
from imimic_gym.estimators.don.motion_mask import MotionMask
from imimic_gym.estimators.joint_range import pointing_range, within_range
from imimic_gym.estimators.motion import PathEstimator, TorqueModel
from imimic_gym.estimators.types import Estimate
from imimic_gym.kinematics import wrap_angle

__all__ = ["LinkedDON"]


class LinkedDON:
    """DON for a tree of moving links (a chain, or the hand's forearm with two fingers).

    Args:
        parents: each link's parent link (-1: the fixed reference); parents come first.
        joint_ranges: each joint's (low, high) limits, rad, relative to its parent.
        fps: frame rate of the video, for rad/s.
        reference_direction: image-plane direction (rad, CCW from image right) of the
            fixed reference link; the root's joint angle is its direction minus this.
        pivot: the root's pivot in input pixels (x, y), if known; else found from the video.
        robot: a MuJoCo model of the robot (n joints), for torques; None gives zero torque.
        config: the settings (`LinkedDONConfig`; `config.linked_don_preset` gives the
            modality's).
        **settings: fields of `LinkedDONConfig` to override in ``config``, e.g.
            ``appearance=False`` (the paper's layers alone) or ``band=7.0``.
    """

    def __init__(
        self,
        parents: Sequence[int],
        joint_ranges: Sequence[tuple[float, float]],
        fps: float = 30.0,
        reference_direction: float = 0.0,
        pivot: tuple[float, float] | None = None,
        robot: mujoco.MjModel | None = None,
        config: LinkedDONConfig | None = None,
        **settings: Any,
    ) -> None:
        config = override(LinkedDONConfig() if config is None else config, settings)
        self.config = config
        self.parents = tuple(int(p) for p in parents)
        self.n = len(self.parents)
        if not 2 <= self.n <= 3:
            raise ValueError(f"LinkedDON follows 2 or 3 links (`DON` follows one), got "
                             f"parents {self.parents}")
        for i, p in enumerate(self.parents):
            if not -1 <= p < i:
                raise ValueError(f"parents must list each link's parent before it (-1 for "
                                 f"the fixed reference), got {self.parents}")
        if len(joint_ranges) != self.n:
            raise ValueError(f"joint_ranges must give (low, high) for each of the {self.n} "
                             f"links, got {len(joint_ranges)}")
        self.joint_ranges = np.array([(float(lo), float(hi)) for lo, hi in joint_ranges])
        if robot is not None and robot.nv != self.n:
            raise ValueError(f"robot model has {robot.nv} joints, the tree has {self.n}")
        self.mask = MotionMask(window=config.window, gaussian=config.gaussian,
                               threshold=config.threshold,
                               working_height=config.working_height,
                               scene_change=config.scene_change, name="LinkedDON")
        self.fps, self.window = float(fps), config.window
        self.reference_direction = float(reference_direction)
        self.known_pivot = None if pivot is None else np.asarray(pivot, dtype=np.float64)
        self.band, self.min_area = float(config.band), config.min_area
        self.torque_model = TorqueModel(robot) if robot is not None else None
        self.chain = Chain(self.parents, self.joint_ranges, self.reference_direction,
                           self.band, config)
        self.children = self.chain.children
        # Any colour, taught by vouched readings only (`LinkedDONConfig.colour`).
        self.appearances = ([LinkAppearance(config.colour) for _ in range(self.n)]
                            if config.appearance else None)
        self.reset()


    def reset(self) -> None:
        config = self.config
        self.mask.reset()
        for layer in self.appearances or ():
            layer.reset()
        self.ends: list[np.ndarray] = []
        self.root_pivot: np.ndarray | None = None
        # Length measurements per link (working px); their median is the link's length.
        self.measured: list[deque[float]] = [deque(maxlen=config.length_memory)
                                          for _ in range(self.n)]
        self.root_joints: deque[np.ndarray] = deque(maxlen=config.length_memory)
        self.fits = 0
        self.recheck_due = False  # a recheck waits for a frame with enough moving pixels
        # Before anything moved: the middle of each joint's range, the guess least far
        # from anywhere the arm can be; trust 0, as it is no reading.
        self.q = self.joint_ranges.mean(axis=1)
        self.tracking = False
        self.path = PathEstimator(self.n, self.fps, self.window)
        self.sizes: deque[float | None] = deque(maxlen=self.window)
        self.estimate = self._estimate(np.zeros(self.n), np.zeros(self.n), trust=0.0)
        self.last_mask: np.ndarray | None = None

    @property
    def scale(self) -> float:
        """Input pixels per working pixel."""
        return self.mask.frames.scale

    def lengths(self) -> np.ndarray | None:
        """(n,) link lengths (working px), the median of each link's measurements; None
        until every link has ``min_measurements``."""
        pivot, least = self.pivot(), self.config.min_measurements
        if pivot is None or len(self.root_joints) < least or any(
                len(m) < least for m in self.measured[1:]):
            return None
        root = float(np.median(np.hypot(*(np.array(self.root_joints) - pivot).T)))
        return np.array([root] + [float(np.median(m)) for m in self.measured[1:]])


    def pivot(self) -> np.ndarray | None:
        """The root's pivot (working px): the given one, else the estimate (None before
        ``pivot_min_ends`` far ends were seen)."""
        return self.known_pivot / self.scale if self.known_pivot is not None else self.root_pivot

    def _find_pivot(self, points: np.ndarray) -> None:
        """Unless given: the place where the moving tree's far ends keep coming back to,
        facing where the root can point (`blob_ends`, `facing_point`), re-solved with
        every frame's ends until ``pivot_ends`` were seen, then fixed. The root's length
        is kept as joint positions, not lengths, so a pivot that moves while it settles
        leaves no stale length, and the measurements are kept when it is fixed; a pivot
        that moves more than the band leaves the pose fitted about the old one untracked
        (the next fit searches the whole ranges)."""
        c = self.config
        if self.known_pivot is None and len(self.ends) < c.pivot_ends:
            self.ends.extend(blob_ends(points))
            if len(self.ends) >= c.pivot_min_ends:
                found = facing_point(np.array(self.ends), self.band / 2, self.band,
                                     pointing_range(self.reference_direction,
                                                    self.joint_ranges[0],
                                                    c.range_margin_deg), c.facing)
                if found is not None:
                    if (self.root_pivot is not None
                            and np.hypot(*(found - self.root_pivot)) > self.band):
                        self.tracking = False
                    self.root_pivot = found

    def _measure_lengths(self, points: np.ndarray, pivot: np.ndarray, tip: np.ndarray) -> None:
        """Object regression without lengths: the tree's corners from this frame's moving
        pixels. The tip is the moving pixel farthest from the pivot; the joint along the
        way is the corner of the polyline pivot -> joint -> tip that best explains the
        pixels (`corner`). A corner is only a length when the polyline bends there by more
        than ``bent_deg`` (along a straight arm any point explains the pixels equally),
        at least the band away from both ends."""
        start, link = pivot, 0
        while self.children[link]:
            joint = corner(points, start, tip, self.band)
            direction = direction_of(joint - start)
            bend = wrap_angle(direction_of(tip - joint) - direction)
            if abs(bend) < math.radians(self.config.bent_deg):
                return
            # A corner within the band of either end is no corner: a point that near an
            # end, a pixel or two off the line, bends it by ``bent_deg``. On the hand such
            # corners put the wrist 6 px from the elbow (the forearm is about 40).
            if min(math.dist(joint, start), math.dist(tip, joint)) < self.band:
                return
            if link == 0:
                self.root_joints.append(joint)
            else:
                self.measured[link].append(float(np.hypot(*(joint - start))))
            offset = points - joint
            distance = np.hypot(*offset.T)
            bearing = np.arctan2(-offset[:, 1], offset[:, 0])
            inner = None
            for c in self.children[link]:
                if self.children[c]:
                    inner = c
                    continue
                # A leaf's length: its farthest moving pixel from the joint, where its
                # joint's range lets it point.
                lo, hi = self.joint_ranges[c]
                middle = direction + (lo + hi) / 2
                half = (hi - lo) / 2 + math.radians(self.config.margin_deg)
                fan = (np.abs(wrap_angle(bearing - middle)) < half) & (distance > 1.0)
                if fan.any():
                    self.measured[c].append(float(distance[fan].max()))
            if inner is None:
                return
            start, link = joint, inner


    def update(self, frame: np.ndarray) -> Estimate:
        """Take the next (H, W, 3) uint8 RGB frame; return the estimate for it."""
        fitted = self._fit(frame)
        if self.appearances is not None and self.tracking:
            self._read_appearance(self.appearances, fitted)
        return self.estimate

    def _fit(self, frame: np.ndarray) -> bool:
        """The paper's layers on the next frame (``self.estimate`` updated where they
        give something new); True where the object regression fitted a pose."""
        mask = self.mask(frame)
        if mask is None:
            return False
        self.last_mask = mask
        if self.mask.scene_changed:  # a cut, a flash or noise: no link's motion
            self.sizes.append(None)
            self._hold(trust=0.0)
            return False
        found = cv2.findNonZero(mask)
        if found is None or len(found) < self.min_area:
            self.sizes.append(None)
            self._hold(trust=1.0)  # nothing moved, nothing to distrust
            return False
        points = found.reshape(-1, 2).astype(np.float64)
        c = self.config
        if len(points) > c.max_points:
            points = points[:: len(points) // c.max_points + 1]
        self._find_pivot(points)
        pivot = self.pivot()
        if pivot is None:
            self.sizes.append(None)
            return False  # nowhere to turn about yet
        # Lengths are measured every frame until each link has ``length_memory``
        # measurements, then every ``measure_every`` frames: a corner costs as much as a fit.
        full = len(self.root_joints) == c.length_memory
        if not full or self.fits % c.measure_every == 0:
            tip = points[int(np.argmax(np.hypot(*(points - pivot).T)))]
            self._measure_lengths(points, pivot, tip)
        lengths = self.lengths()
        if lengths is None:
            self.sizes.append(None)
            return False
        q, _ = self.chain.search(points, pivot, lengths, self.q,
                                 c.gate_deg if self.tracking else 360.0, c.sweeps, self.q)
        self.fits += 1
        self.recheck_due |= self.fits % c.recheck_every == 0
        # A whole-range search on a frame with few moving pixels (the arm starting or
        # stopping) fits their noise: the recheck waits for a fuller frame.
        if self.recheck_due and len(points) >= c.recheck_pixels * max(
                (m for m in self.sizes if m is not None), default=0.0):
            self.recheck_due = False
            q = self.chain.recheck(points, pivot, lengths, q)
        self.sizes.append(float(len(points)))
        self.q = q
        self.tracking = True
        self.path.update(q)
        omega, alpha = self.path.omega(), self.path.alpha()
        self.estimate = self._estimate(omega, alpha, trust=self._trust())
        return True

    def _read_appearance(self, appearances: list[LinkAppearance], fitted: bool) -> None:
        """The appearance layer (ours): each long enough link's direction
        from its colour in this frame, about the estimate's pose; the estimate's angles
        follow. ``appearances``: the layers, one per link. ``fitted``: the fit gave this
        frame's pose (it vouches for it); else the layers search about their own tracks."""
        pivot, lengths = self.pivot(), self.lengths()
        if pivot is None or lengths is None:
            return
        angles = self.estimate.angles
        fitted_directions = self.chain.directions(angles)
        starts, _ = self.chain.joints(angles, pivot, lengths)
        directions = fitted_directions.copy()
        read = 0
        for i, parent in enumerate(self.parents):
            if lengths[i] < self.config.appearance_min_length:
                continue
            base = self.reference_direction if parent < 0 else directions[parent]
            angle = appearances[i].update(
                self.mask.history[-1], starts[i], float(lengths[i]),
                prior=float(fitted_directions[i]), read=fitted, trust=float(fitted),
                directions=pointing_range(base, self.joint_ranges[i]))
            if angle is not None:
                directions[i], read = angle, read + 1
        if read == 0:
            return
        q = self.chain.joint_angles(directions)
        omega, alpha = self.estimate.omega, self.estimate.alpha
        if fitted and read == self.n:
            self.q = q.copy()
            self.path.correct(q)
            omega, alpha = self.path.omega(), self.path.alpha()
        self.estimate = self._estimate(omega, alpha, self.estimate.trust, angles=q)

    def _trust(self) -> float:
        """eta = 1 - max_p |M_1 - M_p| / max_p M_p, paper Eq. (TF), M_p the links' summed
        visible length; 1 with fewer than two measurements."""
        sizes = np.asarray([m for m in self.sizes if m is not None], dtype=np.float64)
        largest = sizes.max() if sizes.size > 1 else 0.0
        if largest <= 0:
            return 1.0
        return float(1.0 - np.max(np.abs(sizes[-1] - sizes)) / largest)

    def _hold(self, trust: float) -> Estimate:
        """Nothing to measure: the arm stays where it was, at rest."""
        if self.tracking:
            self.path.update(self.q)
            self.estimate = self._estimate(np.zeros(self.n), np.zeros(self.n), trust)
        return self.estimate

    def _estimate(self, omega: np.ndarray, alpha: np.ndarray, trust: float,
                  angles: np.ndarray | None = None) -> Estimate:
        """The estimate for ``angles`` (n,) rad; by default the fit's, ``self.q``,
        carried on by half a frame (delta1_1 spans frames t-1 and t: the fit is half a
        frame old). Each angle past its joint's limits is reported at the nearer one
        (`joint_range.within_range`; `docs/decisions/don-joint-limits.md`)."""
        if angles is None:
            angles = wrap_angle(self.q + 0.5 * omega / self.fps)
        # Never past a joint's limits (the fit searches a margin beyond them).
        angles = np.array([within_range(float(q), (lo, hi))
                           for q, (lo, hi) in zip(angles, self.joint_ranges.tolist(), strict=True)])
        torque = (self.torque_model(angles, omega, alpha) if self.torque_model is not None
                  else np.zeros(self.n))
        return Estimate(angles=angles, omega=omega, alpha=alpha, torque=torque,
                        trust=float(np.clip(trust, 0.0, 1.0)), predicted=False,
                        keypoints=self.keypoints(angles))

    def keypoints(self, q: np.ndarray) -> np.ndarray | None:
        """(n + 1, 2) input pixels (x, y): the root pivot, then each link's tip, once the
        pivot and the lengths are known."""
        pivot = self.pivot()
        lengths = self.lengths()
        if pivot is None or lengths is None:
            return None
        _, ends = self.chain.joints(q, pivot, lengths)
        return np.vstack([pivot, ends]) * self.scale

    def run(self, frames: Iterable[np.ndarray]) -> list[Estimate]:
        """Estimates for every frame of an iterable (a clip's frames, a video reader)."""
        self.reset()
        return [self.update(frame) for frame in frames]
