"""LinkedDON's object regression (paper §3, "a line per link") for a tree of links: the
joint angles whose polyline best explains a frame's moving pixels.

In: moving pixels (N, 2) working px (x right, y down); the root pivot (2,) px; link
lengths (n,) px; joint angles (n,) rad, each from its parent's direction (the root's
from the reference direction), CCW with the image's y axis up. Out: joint angles (n,)
rad and their score, the tent-weighted count of pixels near the polyline
(`segment_score`). The links are fitted together, not pixel by pixel, and the root pivot
is found where the moving tree's far ends keep coming back to (`blob_ends`,
`facing_point`): `docs/decisions/linked-don.md`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from imimic_gym.estimators.don.config import LinkedDONConfig
from imimic_gym.kinematics import wrap_angle

__all__ = ["Chain", "blob_ends", "corner", "direction_of", "facing_point", "segment_score",
           "unit_vectors"]


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
                 directions: tuple[float, float], facing: float) -> np.ndarray | None:
    """The root pivot among the far ends of moving trees: the densest place that the
    trees reach out from where the root can point. (2,) px, or None if no place does.

    ``ends``: (2k, 2) px, the two far ends (`blob_ends`) of each of k frames, in pairs.
    A place is an end moved to the mean of the ends within ``radius`` of it; places are
    tried from the most such ends down. A place qualifies when, of the frames with an
    end within ``reach`` of it, at least ``facing`` (a share) have their other end in
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
        if np.mean(np.abs(wrap_angle(bearing - middle)) < half_width) >= facing:
            return point
    return None


def unit_vectors(direction: np.ndarray) -> np.ndarray:
    """(..., 2) image vectors (x right, y down) of directions (rad, CCW, image up)."""
    return np.stack([np.cos(direction), -np.sin(direction)], axis=-1)


def direction_of(vector: np.ndarray) -> float:
    """Direction (rad, CCW, image up) of an image vector (x right, y down)."""
    return math.atan2(-float(vector[1]), float(vector[0]))



class Chain:
    """A tree of links about a root pivot and its fit to moving pixels.

    Args:
        parents: each link's parent link (-1: the fixed reference); parents come first.
        joint_ranges: (n, 2) each joint's (low, high) limits, rad, relative to its parent.
        reference_direction: image direction (rad, CCW from image right) of the fixed
            reference link.
        band: distance (working px) from a link's line at which a moving pixel stops
            counting as the link's.
        config: the search's settings (`LinkedDONConfig`).
    """

    def __init__(self, parents: Sequence[int], joint_ranges: np.ndarray,
                 reference_direction: float, band: float, config: LinkedDONConfig) -> None:
        self.parents, self.n = tuple(parents), len(parents)
        self.joint_ranges, self.reference_direction = joint_ranges, reference_direction
        self.band, self.config = band, config
        self.children = [[c for c, p in enumerate(self.parents) if p == i]
                         for i in range(self.n)]

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
        ends = unit_vectors(self.directions(q)) * lengths[:, None]
        starts = np.zeros_like(ends)
        starts[..., :, :] = pivot
        for i, p in enumerate(self.parents):
            if p >= 0:
                starts[..., i, :] = starts[..., p, :] + ends[..., p, :]
        return starts, starts + ends


    def search(self, points: np.ndarray, pivot: np.ndarray, lengths: np.ndarray,
                q: np.ndarray, gate_deg: float, sweeps: int, last: np.ndarray | None,
                step_deg: float | None = None) -> tuple[np.ndarray, float]:
        """Object regression: the joint angles (n,) whose links best explain the moving
        pixels (`segment_score`), and that score, by coordinate search from ``q``: each
        joint in turn, with the others held, over its range (plus ``margin_deg``) within
        ``gate_deg`` of where it starts, in ``step_deg`` steps, ``sweeps`` times. With
        ``last``, a candidate loses ``stay`` per degree it moves from it, so a link with no
        pixels of its own (at rest) stays where it was instead of wandering."""
        config = self.config
        step_deg = config.step_deg if step_deg is None else step_deg
        q = q.copy()
        margin, gate = math.radians(config.margin_deg), math.radians(gate_deg)
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
                    score -= config.stay * np.degrees(np.abs(values - last[i]))
                best = int(np.argmax(score))
                q, best_score = trial[best], float(score[best])
        return q, best_score

    def recheck(self, points: np.ndarray, pivot: np.ndarray, lengths: np.ndarray,
                 q: np.ndarray) -> np.ndarray:
        """Recover from a wrong lock: coordinate searches over the whole ranges from
        ``restarts`` root angles spread over its range (children at mid-range) against the
        tracked ``q``; the best replaces ``q`` only if it explains ``recheck_gain`` more
        of the pixels. The tracked search only looks ``gate_deg`` around the last angles, so
        a link once placed on the wrong side of its range (a fast first movement, seen
        before the lengths settled) would stay there."""
        starts, ends = self.joints(q[None, :], pivot, lengths)
        tracked = float(segment_score(points, starts, ends, self.band)[0])
        found = self.whole_range(points, pivot, lengths, tracked * (1.0 + self.config.recheck_gain))
        return q if found is None else found

    def whole_range(self, points: np.ndarray, pivot: np.ndarray, lengths: np.ndarray,
                     to_beat: float | None) -> np.ndarray | None:
        """The best of coordinate searches over the whole ranges from ``restarts`` root
        angles spread over its range (children at mid-range); None if it does not score
        above ``to_beat``."""
        best, best_score = None, -np.inf if to_beat is None else to_beat
        middle = self.joint_ranges.mean(axis=1)
        low, high = self.joint_ranges[0]
        c = self.config
        for root in np.linspace(low, high, c.restarts):
            start = middle.copy()
            start[0] = root
            found, score = self.search(points, pivot, lengths, start, 360.0, c.sweeps, None,
                                       c.coarse_step_deg)
            found, score = self.search(points, pivot, lengths, found, c.coarse_step_deg, 1, None)
            if score > best_score:
                best, best_score = found, score
        return best
