"""DON for a tree of 2-3 links: the paper's object regression layer (§3, "a line per
link"), on top of DON's layers 1-3 (`don.MotionMask`).

The paper fits a straight line per link to the moving pixels and takes the joint angles
as the angles between the lines, but never says which moving pixel belongs to which link
or where a moving link's pivot is. Decisions (each also noted where it acts):

- Links are not assigned pixels one by one. The lines of all links are fitted together:
  the joint angles whose polyline (root pivot, then each link's length along its
  direction) best explains this frame's moving pixels l_1 (`segment_score`) win. Fitting
  regions to links one at a time failed on the rendered chains: the upper arm's and the
  forearm's moving pixels join at the elbow into one region, and the forearm's pixels
  pulled the upper arm's line off. A child's pivot is its parent's tip, which moves; it
  comes out of the fit, never from a fixed point.
- A link at rest has no moving pixels of its own. The fit turns the root with its
  children's image directions held, so the forearm's pixels alone place the elbow, and a
  joint loses `STAY` per degree it moves from its last angle, so a link nothing pins
  down holds its angle. A joint turns at most `GATE_DEG` per frame: a frame with a few
  dozen moving pixels (the arm stopping) can otherwise flip a link.
- The root pivot (the shoulder, or the elbow for the hand) is given, or found as the
  place where the moving tree's far ends keep coming back to (`blob_ends`,
  `facing_point`): the tips sweep about, the pivot end stays. Not any such place: one
  from which the tree's other end lies where the root can point. Over the first few
  frames the arm often moves slowly, its tip recurs as much as the pivot end, and the
  densest place at the first solve lay 20-51 px off (mostly at the tip) on 27 of the
  first 30 development chain-2 clips; a pose fitted about it locked the shoulder 100
  degrees off until the recheck. A first pivot after `PIVOT_MIN_ENDS` ends, re-solved
  each frame until `PIVOT_ENDS`, then fixed. The lengths measured while it settled are
  kept: they were dropped once, when the first pivot was usually the hand, but a corner
  needs the elbow bent by `BENT_DEG`, so on a straight arm the fit then sat idle for up
  to 18 frames (development chain-2 clip 22); keeping them, development clips went
  chain-2 4.52/4.60 -> 3.34/3.88 deg per joint, chain-3 10.42/15.52/22.46 ->
  10.63/14.51/22.07, exp4-hand 12.10/21.81/16.11 -> 10.59/22.11/15.65
  (`benchmarks/don_links_dev_seeds.py`). A pivot that moves by more than the band while
  it settles drops the tracked pose: the next fit searches the whole ranges, since a
  pose fitted about another point says nothing about this one. The one-link pivot
  (`geometry.PivotEstimator`, the mode of crossing region axes) was tried and lands on
  the elbow's crossings, 20 px off on chain-2. Known bias: on chain-2 the found pivot
  sits about 5 px below the shoulder keypoint, where the arm leaves the torso's outline.
  Refining it by the fit's score made the angles worse. The least-squares crossing of
  the root link's colour lines (the appearance layer's, 60 fitted frames) lies about 1
  working px from the shoulder where the found pivot lies 3, but with the colour kept
  (below) it made development chain-2 worse (2.14/2.72 -> 2.33/3.08 deg), and on the
  hand, whose forearm's skin runs on into the fingers, it lies 1-10 px off the elbow.
- A wrong lock must not last: every `RECHECK_EVERY` fitted frames, searches from
  `RESTARTS` root angles across the whole ranges compete with the tracked pose, which a
  pose explaining `RECHECK_GAIN` more of the pixels replaces. Also while the pivot
  settles: the first lengths come from three measurements, and a pose fitted with them
  can lock as wrongly as one about a wrong pivot. A recheck due on a frame with under
  `RECHECK_PIXELS` of the window's most moving pixels waits for a fuller one: on the 44
  pixels of an arm starting to move, a search over the whole ranges flipped the elbow
  by 100 degrees (development chain-2 clip 21), and the pose stayed flipped until the
  next recheck.
- The facing pivot, the dropped pose, the rechecks while settling and on fuller frames
  and the corner rule below, together, on development clips
  (`benchmarks/don_links_dev_seeds.py`, here and at commit 971e89b before them),
  settled RMSE per joint: chain-2 seeds 0-29 12.85/9.04 -> 4.52/4.60 deg, chain-3 seeds
  0-19 23.51/24.09/30.36 -> 10.42/15.52/22.46, exp4-hand seeds 0-39 12.10/32.92/18.54
  -> 12.10/21.81/16.11. The fuller-frame rule's share, against commit af555f7 (the
  others): 4.65/5.56 -> 4.52/4.60, 11.37/17.24/24.94 -> 10.42/15.52/22.46,
  12.07/23.54/17.56 -> 12.10/21.81/16.11.
- Link lengths are not known from the video a priori. The tip of the tree is the moving
  pixel farthest from the pivot; each joint is the corner of the polyline pivot -> joint
  -> tip that best explains the pixels (`corner`), measured only where the polyline
  bends by more than `BENT_DEG` (along a straight arm any point fits), at least the band
  from both ends (a point a pixel off the line next to an end bends it that much); a
  leaf's length is its farthest moving pixel from its joint inside its joint's range. A
  length is the median of its measurements; the links are followed once each has
  `MIN_MEASUREMENTS`.
- Binarisation threshold 4 grey levels, not the one-link DON's 12: the upper arm's blue
  sleeve against the blue-grey wall barely differs, and without its pixels the elbow is
  placed by the forearm alone (chosen on chain-2 seeds 0-4, as were band 9 px and
  `STAY` 0.5; checked on seeds 5-9; 3 and 6 both did worse than 4).
- Torque is the robot model's inverse dynamics (`motion.TorqueModel`, ``mj_inverse``), so
  coupling and gravity count. eta is the paper's Eq. (TF) with M_p the area of l_p,
  as the paper has it. No n-link occlusion scenario exists to tune a prediction layer
  on, so ``predicted`` is always False here; frames without motion hold the estimate.
- The mask spans frames t-1 and t, so the fit lags by half a frame; the reported angles
  are q + omega / (2 fps), as in the one-link DON.
- Appearance layer (ours, as in the one-link DON; `appearance.py`). The fit places the
  elbow on the forearm's line, but where along it depends on the upper arm's length,
  measured in pixels that are often the forearm's: with the true shoulder given, the
  shoulder and elbow joints of chain-2 were off by -6.0 and +6.1 degrees on average,
  with the forearm's image direction right (held-out clips, `don_known_pivot.py`,
  before this layer). A line fitted to a link's colour gives its
  direction without any length. Each link `APPEARANCE_MIN_LENGTH` px or longer gets a
  `LinkAppearance`, about the link's start in the fitted pose (the elbow for the
  forearm), searched about its fitted direction; every fitted frame vouches for the fit
  (this eta is the area of l_p, about 0.5 on clear clips, and says nothing about the
  fit). A link it reads takes that direction, the joint angles follow from the image
  directions. Only when it reads every link does the corrected pose replace the fit's
  for the next frame's search (and in the path estimator): half a pose corrected (a
  parent by colour, its short child still the fit's) dragged the next search off, and
  chain-3's wrist went from 33.5 to 42.8 degrees (development seeds 0-9). Fingers and
  a hand a few pixels long hold too few pixels to read; they keep the fit's direction.
  A layer learns its colour anew only after `appearance.RELEARN` fitted frames running
  without a reading, not (as for the one-link DON) when it reads the link more than 6
  degrees from the fit: the fit about a found pivot runs 10-15 degrees off for dozens
  of frames (the pivot 3 working px off a 20 px upper arm), the colour then reads the
  link right, and the relearning threw it away every five frames, each time leaving
  the next frame to the fit. On development clips (`benchmarks/don_links_dev_seeds.py`)
  settled RMSE per joint went chain-2 3.34/3.88 -> 2.14/2.72 deg, chain-3
  10.63/14.51/22.07 -> 3.48/8.46/20.44, exp4-hand 10.59/22.11/15.65 ->
  10.35/22.86/15.14.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Iterable, Sequence

import cv2
import mujoco
import numpy as np

from imimic_gym.estimators.appearance import LinkAppearance
from imimic_gym.estimators.don import MotionMask
from imimic_gym.estimators.geometry import pointing_range, within_range
from imimic_gym.estimators.motion import PathEstimator, TorqueModel
from imimic_gym.estimators.types import Estimate
from imimic_gym.kinematics import wrap_angle

__all__ = ["LinkedDON"]

MARGIN_DEG = 15.0  # how far past its joint range a link may still be searched for
GATE_DEG = 15.0  # how far a joint may turn in one frame
STEP_DEG = 1.0  # the direction search's resolution
BENT_DEG = 25.0  # a joint bent by less than this has no measurable position
LENGTH_MEMORY = 60  # length measurements kept per link
MIN_MEASUREMENTS = 3  # before the links are followed
MEASURE_EVERY = 4  # fitted frames between length measurements once the memory is full
PIVOT_MIN_ENDS = 16  # far ends of moving trees seen before a first root pivot
PIVOT_ENDS = 60  # far ends of moving trees seen before the root pivot is fixed
FACING = 0.5  # share of a pivot's trees that must reach where the root can point
MAX_POINTS = 600  # moving pixels the fit looks at (evenly subsampled beyond)
SWEEPS = 2  # coordinate-search passes per frame
RECHECK_EVERY = 10  # fitted frames between searches of the whole ranges
COARSE_STEP_DEG = 3.0  # their resolution, refined to `STEP_DEG` about the best
RESTARTS = 6  # root angles those searches start from
RECHECK_GAIN = 0.1  # how much more a pose found there must explain to replace the tracked
RECHECK_PIXELS = 0.5  # share of the window's most moving pixels a frame needs for one
STAY = 0.5  # score lost per degree a joint moves from its last angle
APPEARANCE_MIN_LENGTH = 12.0  # working px: a shorter link is too few pixels to read


def segment_score(points: np.ndarray, starts: np.ndarray, ends: np.ndarray,
                  band: float) -> np.ndarray:
    """How well polylines explain the moving pixels: for each of K candidate sets of S
    segments, the sum over ``points`` (N, 2) of max(0, 1 - d / band), d the distance
    (px) to the nearest segment. ``starts``, ``ends``: (K, S, 2). Returns (K,) float.

    A tent rather than a count inside a strip: the moving pixels of a fast link form a
    blob wider than the link, and a count would be flat across it; the tent peaks on its
    middle line.

    Written out per coordinate on (K, S, N) arrays, in place where it can be, and with
    the square root after the minimum over segments: 2.5 times faster than with einsum
    over (K, S, N, 2) arrays, the same scores to 1e-14."""
    px, py = points[:, 0], points[:, 1]
    sx, sy = starts[..., 0, None], starts[..., 1, None]  # (K, S, 1)
    dx, dy = ends[..., 0, None] - sx, ends[..., 1, None] - sy
    rx, ry = px - sx, py - sy  # (K, S, N): from each segment's start to each point
    # t: where along the segment the nearest point lies, 0 (start) to 1 (end).
    t = rx * dx
    t += ry * dy
    t *= 1.0 / np.maximum(dx * dx + dy * dy, 1e-9)
    np.clip(t, 0.0, 1.0, out=t)
    rx -= t * dx
    ry -= t * dy
    rx *= rx
    ry *= ry
    rx += ry  # squared distance to each segment
    d = np.sqrt(rx.min(axis=1))  # (K, N)
    d *= -1.0 / band
    d += 1.0
    return np.maximum(d, 0.0, out=d).sum(axis=1)


def corner(points: np.ndarray, start: np.ndarray, tip: np.ndarray, band: float,
           candidates: int = 200) -> np.ndarray:
    """The joint between two links: the point C (among the moving pixels, at most
    ``candidates`` of them tried) whose polyline start -> C -> tip best explains
    ``points`` (`segment_score`). (2,) px."""
    step = max(1, len(points) // candidates)
    trial = points[::step]
    k = len(trial)
    starts = np.stack([np.broadcast_to(start, (k, 2)), trial], axis=1)
    ends = np.stack([trial, np.broadcast_to(tip, (k, 2))], axis=1)
    return trial[int(np.argmax(segment_score(points, starts, ends, band)))]


def blob_ends(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The two far ends (2,) px of a set of moving pixels (k, 2): the pixel farthest from
    their centre, and the pixel farthest from that one."""
    first = points[int(np.argmax(np.hypot(*(points - points.mean(axis=0)).T)))]
    return first, points[int(np.argmax(np.hypot(*(points - first).T)))]


def facing_point(ends: np.ndarray, radius: float, reach: float,
                 directions: tuple[float, float]) -> np.ndarray | None:
    """The root pivot among the far ends of moving trees: the densest place that the
    trees reach out from where the root can point. (2,) px, or None if no place does.

    ``ends``: (2k, 2) px, the two far ends (`blob_ends`) of each of k frames, in pairs.
    A place is an end moved to the mean of the ends within ``radius`` of it; places are
    tried from the most such ends down. A place qualifies when, of the frames with an
    end within ``reach`` of it, at least `FACING` have their other end in
    ``directions`` (middle, half-width, rad) seen from it: from the shoulder the hand
    lies where the shoulder joint can turn the arm, from the hand the shoulder often
    does not.
    """
    distance = np.hypot(*(ends[:, None, :] - ends[None, :, :]).transpose(2, 0, 1))
    near = distance < radius
    pairs = ends.reshape(-1, 2, 2)
    middle, half_width = directions
    for index in np.argsort(-near.sum(axis=1), kind="stable"):
        point = ends[near[index]].mean(axis=0)
        gap = np.hypot(*(pairs - point).transpose(2, 0, 1))  # (k, 2)
        from_here = gap.min(axis=1) < reach
        if not from_here.any():
            continue
        other = pairs[np.arange(len(pairs)), np.argmax(gap, axis=1)][from_here] - point
        bearing = np.arctan2(-other[:, 1], other[:, 0])
        if np.mean(np.abs(wrap_angle(bearing - middle)) < half_width) >= FACING:
            return point
    return None


def _unit(direction: np.ndarray) -> np.ndarray:
    """(..., 2) image vectors (x right, y down) of directions (rad, CCW, image up)."""
    return np.stack([np.cos(direction), -np.sin(direction)], axis=-1)


def _direction(vector: np.ndarray) -> float:
    """Direction (rad, CCW, image up) of an image vector (x right, y down)."""
    return math.atan2(-float(vector[1]), float(vector[0]))


class LinkedDON:
    """DON for a tree of moving links (a chain, or the hand's forearm with two fingers).

    Args:
        parents: each link's parent link (-1: the fixed reference); parents come first.
        joint_ranges: each joint's (low, high) limits, rad, relative to its parent.
        fps: frame rate of the video, for rad/s.
        reference_direction: image-plane direction (rad, CCW from image right) of the
            fixed reference link; the root's joint angle is its direction minus this.
        pivot: the root's pivot in input pixels (x, y), if known; else found from the video.
        window, gaussian, threshold, working_height: DON layers 1-2 (`MotionMask`).
        band: distance (working px) from a link's line at which a moving pixel stops
            counting as the link's.
        robot: a MuJoCo model of the robot (n joints), for torques; None gives zero torque.
        min_area: fewest moving pixels (working resolution) that count as motion.
        appearance: run the appearance layer (ours; see the module docstring) after the
            fit; False for the paper's layers alone.
    """

    def __init__(
        self,
        parents: Sequence[int],
        joint_ranges: Sequence[tuple[float, float]],
        fps: float = 30.0,
        reference_direction: float = 0.0,
        pivot: tuple[float, float] | None = None,
        window: int = 10,
        gaussian: int = 15,
        threshold: int = 4,
        working_height: int = 120,
        band: float = 9.0,
        robot: mujoco.MjModel | None = None,
        min_area: int = 12,
        appearance: bool = True,
    ) -> None:
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
        self.mask = MotionMask(window, gaussian, threshold, working_height, name="LinkedDON")
        self.fps, self.window = float(fps), window
        self.reference_direction = float(reference_direction)
        self.known_pivot = None if pivot is None else np.asarray(pivot, dtype=np.float64)
        self.band, self.min_area = float(band), min_area
        self.torque_model = TorqueModel(robot) if robot is not None else None
        self.children = [[c for c, p in enumerate(self.parents) if p == i]
                         for i in range(self.n)]
        # Any colour: the links of a chain often share one (see appearance.MAX_SHARE);
        # taught by vouched readings only, as it was chosen on its development clips.
        self.appearances = ([LinkAppearance(disagree=math.inf, max_share=None,
                                            first_trust=None)
                             for _ in range(self.n)] if appearance else None)
        self.reset()

    def reset(self) -> None:
        self.mask.reset()
        for layer in self.appearances or ():
            layer.reset()
        self.ends: list[np.ndarray] = []
        self.root_pivot: np.ndarray | None = None
        # Length measurements per link (working px); their median is the link's length.
        self.measured: list[deque[float]] = [deque(maxlen=LENGTH_MEMORY) for _ in range(self.n)]
        self.root_joints: deque[np.ndarray] = deque(maxlen=LENGTH_MEMORY)
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
        until every link has ``MIN_MEASUREMENTS``."""
        pivot = self.pivot()
        if pivot is None or len(self.root_joints) < MIN_MEASUREMENTS or any(
                len(m) < MIN_MEASUREMENTS for m in self.measured[1:]):
            return None
        root = float(np.median(np.hypot(*(np.array(self.root_joints) - pivot).T)))
        return np.array([root] + [float(np.median(m)) for m in self.measured[1:]])

    def directions(self, q: np.ndarray) -> np.ndarray:
        """(..., n) absolute image directions (rad) of the links for joint angles ``q``
        (..., n)."""
        out = np.array(q, dtype=np.float64, copy=True)
        for i, p in enumerate(self.parents):
            out[..., i] += self.reference_direction if p < 0 else out[..., p]
        return out

    def joint_angles(self, directions: np.ndarray) -> np.ndarray:
        """(n,) joint angles (rad, wrapped) for the links' absolute image directions
        (n,) rad: the inverse of `directions`."""
        parents = np.array([self.reference_direction if p < 0 else directions[p]
                            for p in self.parents])
        return wrap_angle(directions - parents)

    def joints(self, q: np.ndarray, pivot: np.ndarray, lengths: np.ndarray
               ) -> tuple[np.ndarray, np.ndarray]:
        """Each link's (start, end), (..., n, 2) working px, for joint angles (..., n)."""
        ends = _unit(self.directions(q)) * lengths[:, None]
        starts = np.zeros_like(ends)
        starts[..., :, :] = pivot
        for i, p in enumerate(self.parents):
            if p >= 0:
                starts[..., i, :] = starts[..., p, :] + ends[..., p, :]
        return starts, starts + ends

    def pivot(self) -> np.ndarray | None:
        """The root's pivot (working px): the given one, else the estimate (None before
        ``PIVOT_MIN_ENDS`` far ends were seen)."""
        return self.known_pivot / self.scale if self.known_pivot is not None else self.root_pivot

    def _find_pivot(self, points: np.ndarray) -> None:
        """Unless given: the place where the moving tree's far ends keep coming back to,
        facing where the root can point (`blob_ends`, `facing_point`), re-solved with
        every frame's ends until ``PIVOT_ENDS`` were seen, then fixed. The root's length
        is kept as joint positions, not lengths, so a pivot that moves while it settles
        leaves no stale length, and the measurements are kept when it is fixed; a pivot
        that moves more than the band leaves the pose fitted about the old one untracked
        (the next fit searches the whole ranges)."""
        if self.known_pivot is None and len(self.ends) < PIVOT_ENDS:
            self.ends.extend(blob_ends(points))
            if len(self.ends) >= PIVOT_MIN_ENDS:
                found = facing_point(np.array(self.ends), self.band / 2, self.band,
                                     pointing_range(self.reference_direction,
                                                    self.joint_ranges[0]))
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
        than ``BENT_DEG`` (along a straight arm any point explains the pixels equally),
        at least the band away from both ends."""
        start, link = pivot, 0
        while self.children[link]:
            joint = corner(points, start, tip, self.band)
            direction = _direction(joint - start)
            bend = wrap_angle(_direction(tip - joint) - direction)
            if abs(bend) < math.radians(BENT_DEG):
                return
            # A corner within the band of either end is no corner: a point that near an
            # end, a pixel or two off the line, bends it by BENT_DEG. On the hand such
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
                half = (hi - lo) / 2 + math.radians(MARGIN_DEG)
                fan = (np.abs(wrap_angle(bearing - middle)) < half) & (distance > 1.0)
                if fan.any():
                    self.measured[c].append(float(distance[fan].max()))
            if inner is None:
                return
            start, link = joint, inner

    def _search(self, points: np.ndarray, pivot: np.ndarray, lengths: np.ndarray,
                q: np.ndarray, gate_deg: float, sweeps: int, last: np.ndarray | None,
                step_deg: float = STEP_DEG) -> tuple[np.ndarray, float]:
        """Object regression: the joint angles (n,) whose links best explain the moving
        pixels (`segment_score`), and that score, by coordinate search from ``q``: each
        joint in turn, with the others held, over its range (plus `MARGIN_DEG`) within
        ``gate_deg`` of where it starts, in ``step_deg`` steps, ``sweeps`` times. With
        ``last``, a candidate loses `STAY` per degree it moves from it, so a link with no
        pixels of its own (at rest) stays where it was instead of wandering."""
        q = q.copy()
        margin, gate = math.radians(MARGIN_DEG), math.radians(gate_deg)
        best_score = 0.0
        for _ in range(sweeps):
            for i in range(self.n):
                lo, hi = self.joint_ranges[i]
                values = np.arange(max(lo - margin, q[i] - gate),
                                   min(hi + margin, q[i] + gate) + 1e-9, math.radians(step_deg))
                if len(values) == 0:
                    continue
                trial = np.repeat(q[None, :], len(values), axis=0)
                trial[:, i] = values
                # A joint turns with its children's image directions held: the forearm's
                # pixels then fix where the elbow is, even when the upper arm is at rest.
                for c in self.children[i]:
                    trial[:, c] -= values - q[i]
                starts, ends = self.joints(trial, pivot, lengths)
                score = segment_score(points, starts, ends, self.band)
                if last is not None:
                    score -= STAY * np.degrees(np.abs(values - last[i]))
                best = int(np.argmax(score))
                q, best_score = trial[best], float(score[best])
        return q, best_score

    def _recheck(self, points: np.ndarray, pivot: np.ndarray, lengths: np.ndarray,
                 q: np.ndarray) -> np.ndarray:
        """Recover from a wrong lock: coordinate searches over the whole ranges from
        `RESTARTS` root angles spread over its range (children at mid-range) against the
        tracked ``q``; the best replaces ``q`` only if it explains `RECHECK_GAIN` more
        of the pixels. The tracked search only looks `GATE_DEG` around the last angles, so
        a link once placed on the wrong side of its range (a fast first movement, seen
        before the lengths settled) would stay there."""
        starts, ends = self.joints(q[None, :], pivot, lengths)
        tracked = float(segment_score(points, starts, ends, self.band)[0])
        found = self._whole_range(points, pivot, lengths, tracked * (1.0 + RECHECK_GAIN))
        return q if found is None else found

    def _whole_range(self, points: np.ndarray, pivot: np.ndarray, lengths: np.ndarray,
                     to_beat: float | None) -> np.ndarray | None:
        """The best of coordinate searches over the whole ranges from `RESTARTS` root
        angles spread over its range (children at mid-range); None if it does not score
        above ``to_beat``."""
        best, best_score = None, -np.inf if to_beat is None else to_beat
        middle = self.joint_ranges.mean(axis=1)
        low, high = self.joint_ranges[0]
        for root in np.linspace(low, high, RESTARTS):
            start = middle.copy()
            start[0] = root
            found, score = self._search(points, pivot, lengths, start, 360.0, SWEEPS, None,
                                        COARSE_STEP_DEG)
            found, score = self._search(points, pivot, lengths, found, COARSE_STEP_DEG, 1, None)
            if score > best_score:
                best, best_score = found, score
        return best

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
        if len(points) > MAX_POINTS:
            points = points[:: len(points) // MAX_POINTS + 1]
        self._find_pivot(points)
        pivot = self.pivot()
        if pivot is None:
            self.sizes.append(None)
            return False  # nowhere to turn about yet
        # Lengths are measured every frame until each link has `LENGTH_MEMORY`
        # measurements, then every `MEASURE_EVERY` frames: a corner costs as much as a fit.
        full = len(self.root_joints) == LENGTH_MEMORY
        if not full or self.fits % MEASURE_EVERY == 0:
            tip = points[int(np.argmax(np.hypot(*(points - pivot).T)))]
            self._measure_lengths(points, pivot, tip)
        lengths = self.lengths()
        if lengths is None:
            self.sizes.append(None)
            return False
        q, _ = self._search(points, pivot, lengths, self.q,
                            GATE_DEG if self.tracking else 360.0, SWEEPS, self.q)
        self.fits += 1
        self.recheck_due |= self.fits % RECHECK_EVERY == 0
        # A whole-range search on a frame with few moving pixels (the arm starting or
        # stopping) fits their noise: the recheck waits for a fuller frame.
        if self.recheck_due and len(points) >= RECHECK_PIXELS * max(
                (m for m in self.sizes if m is not None), default=0.0):
            self.recheck_due = False
            q = self._recheck(points, pivot, lengths, q)
        self.sizes.append(float(len(points)))
        self.q = q
        self.tracking = True
        self.path.update(q)
        omega, alpha = self.path.omega(), self.path.alpha()
        self.estimate = self._estimate(omega, alpha, trust=self._trust())
        return True

    def _read_appearance(self, appearances: list[LinkAppearance], fitted: bool) -> None:
        """The appearance layer (module docstring): each long enough link's direction
        from its colour in this frame, about the estimate's pose; the estimate's angles
        follow. ``appearances``: the layers, one per link. ``fitted``: the fit gave this
        frame's pose (it vouches for it); else the layers search about their own tracks."""
        pivot, lengths = self.pivot(), self.lengths()
        if pivot is None or lengths is None:
            return
        angles = self.estimate.angles
        fitted_directions = self.directions(angles)
        starts, _ = self.joints(angles, pivot, lengths)
        directions = fitted_directions.copy()
        read = 0
        for i, parent in enumerate(self.parents):
            if lengths[i] < APPEARANCE_MIN_LENGTH:
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
        q = self.joint_angles(directions)
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
        (`geometry.within_range`): development clips, settled RMSE per joint, without ->
        with (`benchmarks/don_links_dev_seeds.py`): `exp4-hand` 10.34, 22.84, 15.20 ->
        10.20, 20.48, 13.82 deg (the fingers' ranges are narrow: 60 and 50 degrees),
        `chain-3` 3.06, 7.89, 20.35 -> 3.06, 7.80, 20.35, `chain-2` 2.21, 2.83 -> 2.21,
        2.81."""
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
        _, ends = self.joints(q, pivot, lengths)
        return np.vstack([pivot, ends]) * self.scale

    def run(self, frames: Iterable[np.ndarray]) -> list[Estimate]:
        """Estimates for every frame of an iterable (a clip's frames, a video reader)."""
        self.reset()
        return [self.update(frame) for frame in frames]
