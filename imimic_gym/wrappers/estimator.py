"""Estimator observation wrappers: add ``obs["estimate"]`` computed from ``obs["frame"]``.

The estimator is an object (any `Estimator`); the wrapper only feeds it frames, so the
env knows nothing about estimators and estimators know nothing about the env. Estimators
by name come from the registry (`estimators.registry`), set up from the context the env
publishes (`ImitateVideoEnv.estimator_context`): `RegistryObservation`.
"""

from __future__ import annotations

import time
from typing import Any, cast

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from imimic_gym.estimators.registry import (
    build_estimator,
    build_spatial_estimator,
    get_estimator,
)
from imimic_gym.estimators.types import (
    ESTIMATE_BOUNDS,
    Estimate,
    Estimator,
    EstimatorContext,
    estimate_fields,
)

__all__ = [
    "CNNObservation", "DONObservation", "EstimatorObservation", "RegistryObservation",
    "TruthObservation", "draw_estimate", "estimate_fields", "estimator_context",
]


def estimator_context(env: gym.Env) -> EstimatorContext:
    """The `EstimatorContext` that ``env`` (an ImitateVideo env, wrapped or not)
    publishes for its current clip."""
    return env.get_wrapper_attr("estimator_context")()


def draw_estimate(picture: np.ndarray, estimate: Estimate,
                  parents: tuple[int, ...] | None = None, scale: float = 1.0,
                  caption: str | None = None) -> np.ndarray:
    """A copy of ``picture`` (H, W', 3) uint8 RGB with ``estimate`` drawn on it: its
    keypoints (input pixels, (x, y): the root pivot, then each link's tip) joined as links
    in yellow, a dot at each joint, and a line of text with the angles (deg) and eta;
    cyan text while the prediction layer speaks for the frame.

    ``parents``: each link's parent link (-1: the root pivot), as `ArmSpec.link_parents`;
    None for a chain. A link is drawn from its parent's tip, so the hand's thumb and index
    finger both start at the wrist. ``scale``: picture pixels per input pixel (a preview
    drawn smaller than the frames the estimator read). ``caption``: the line of text
    instead of the angles and eta (a spatial estimator's reading, say)."""
    import cv2

    out = picture.copy()
    size = max(1.0, picture.shape[0] / 240)  # drawn the same at any resolution
    line, dot = max(2, round(2 * size)), max(4, round(4 * size))
    if estimate.keypoints is not None:
        points = [(int(x), int(y))
                  for x, y in np.rint(scale * estimate.keypoints).astype(np.int32)]
        n = len(points) - 1
        links = parents if parents is not None else tuple(range(-1, n - 1))
        for link, parent in enumerate(links[:n]):
            cv2.line(out, points[parent + 1], points[link + 1], (255, 220, 0), line,
                     cv2.LINE_AA)
        for joint in {0, *(parent + 1 for parent in links[:n] if parent >= 0)}:
            cv2.circle(out, points[joint], dot, (255, 220, 0), -1, cv2.LINE_AA)
    angles = " ".join(f"{np.degrees(q):+.0f}" for q in estimate.angles)
    text = caption or f"estimate {angles} deg  eta {estimate.trust:.2f}"
    colour = (0, 230, 255) if estimate.predicted else (255, 220, 0)
    origin, font = (round(6 * size), round(16 * size)), 0.45 * size
    width = max(1, round(size))
    # On a dark box, not over a thicker black copy: OpenCV advances each glyph by its
    # stroke's thickness, so a thicker copy drifts off the text along the line.
    (w, h), below = cv2.getTextSize(text, cv2.FONT_HERSHEY_SIMPLEX, font, width)
    pad = max(1, round(2 * size))
    cv2.rectangle(out, (origin[0] - pad, origin[1] - h - pad),
                  (origin[0] + w + pad, origin[1] + below), (0, 0, 0), -1)
    cv2.putText(out, text, origin, cv2.FONT_HERSHEY_SIMPLEX, font, colour, width, cv2.LINE_AA)
    return out


class EstimatorObservation(gym.ObservationWrapper, gym.utils.RecordConstructorArgs):
    """Adds ``obs["estimate"]``: `Box` (4n + 2,) float32 = angles (rad), omega (rad/s),
    alpha (rad/s^2), torque (N m), trust eta, predicted (0/1); see `estimate_fields`.
    Values beyond the space's bounds are clipped to them.

    Args:
        env: an env whose observation is a Dict with ``frame`` (H, W, 3) uint8.
        estimator: the `Estimator` to feed; it is reset on every ``env.reset``. An env
            rebuilt from this wrapper's spec shares the same estimator object; build a
            new wrapper (or use `DONObservation`) for a second env.
        keep_frame: False drops ``frame`` from the observation (controllers that do not
            look at pixels train faster without it).
        estimate_ahead: True, for an estimator with a ``prefetch(frame)`` hook (the pose
            estimators' `PoseEstimator.prefetch`): each observation's frame is estimated,
            and the frame the env will observe next (``upcoming_frame()``,
            `ImitateVideoEnv.upcoming_frame`: the very array of its next observation; None
            where it is not known ahead, a camera's) is handed over to it before, so that
            the estimator reads it while the caller works on this one. The estimates are
            the same. Nothing between the env and this wrapper may replace the frame.
        ahead_when_drawn: with ``estimate_ahead``, the next frame is taken when the
            picture is drawn (`render`, after the step and the command the caller sent
            from it), not when the observation is made: a camera's next frame, which
            ``upcoming_frame(wait=True)`` waits for. The pose model then reads it while
            this frame's picture is drawn and written, and the wait holds up no command.
            Without a `render` each step, frames are estimated when observed, as without
            ``estimate_ahead``.
    """

    def __init__(self, env: gym.Env, estimator: Estimator, keep_frame: bool = True,
                 estimate_ahead: bool = False, ahead_when_drawn: bool = False) -> None:
        space = env.observation_space
        if not isinstance(space, spaces.Dict) or "frame" not in space.spaces:
            raise TypeError(
                f"EstimatorObservation needs a Dict observation space with a 'frame' key, "
                f"got {space}"
            )
        frame = space["frame"]
        if not (isinstance(frame, spaces.Box) and frame.dtype == np.uint8
                and len(frame.shape) == 3 and frame.shape[2] == 3):
            raise TypeError(f"obs['frame'] must be a Box (H, W, 3) uint8, got {frame}")
        # Recorded so gym.make(env.spec) can rebuild the stack; a subclass that records
        # its own arguments first keeps those (the first record wins).
        gym.utils.RecordConstructorArgs.__init__(self, estimator=estimator, keep_frame=keep_frame,
                                                 estimate_ahead=estimate_ahead,
                                                 ahead_when_drawn=ahead_when_drawn)
        gym.ObservationWrapper.__init__(self, env)
        self.estimator, self.keep_frame = estimator, keep_frame
        action_shape = env.action_space.shape
        if action_shape is None:
            raise TypeError(f"EstimatorObservation needs an action space with a shape, got "
                            f"{env.action_space}")
        self.n = int(action_shape[0])
        low = np.concatenate([np.full(self.n, -b) for b in ESTIMATE_BOUNDS.values()]
                             + [[0.0, 0.0]])
        self._low, self._high = low.astype(np.float32), (-low).astype(np.float32)
        self._high[-2:] = 1.0
        subspaces = dict(space.spaces)
        if not keep_frame:
            subspaces.pop("frame")
        subspaces["estimate"] = spaces.Box(self._low, self._high, dtype=np.float32)
        self.observation_space = spaces.Dict(subspaces)
        self.last_estimate: Estimate | None = None
        self._parents = estimator_context(env).link_parents
        self._frame_height = int(frame.shape[0])
        prefetch = getattr(estimator, "prefetch", None)
        self._prefetch = prefetch if estimate_ahead and callable(prefetch) else None
        self._upcoming = env.get_wrapper_attr("upcoming_frame") if self._prefetch else None
        self._ahead_when_drawn = ahead_when_drawn
        self._ahead: np.ndarray | None = None  # the frame handed to prefetch last
        self._ahead_asked: float | None = None  # when render asked the env for it
        # `time.perf_counter()` when the last observation's frame was asked of the env
        # (read ahead by `render`, ``ahead_when_drawn``); None: asked for by the step.
        self.frame_asked: float | None = None

    def reset(self, **kwargs: Any) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        self._ahead = self._ahead_asked = None
        self.estimator.reset()
        return super().reset(**kwargs)

    def warm_up(self) -> None:
        """The estimator's ``warm_up``, if it has one (a pose model's first reading, done
        on a blank frame, so that the first frame reads at full speed); else nothing.
        What the estimator reads is unchanged."""
        warm_up = getattr(self.estimator, "warm_up", None)
        if callable(warm_up):
            warm_up()

    def close(self) -> None:
        """The env's ``close`` and the estimator's, if it has one (a pose model's thread
        stops)."""
        try:
            super().close()
        finally:
            close = getattr(self.estimator, "close", None)
            if callable(close):
                close()

    def render(self) -> np.ndarray | None:
        """The env's (H, 2W, 3) uint8 picture, video left and robot right, with what the
        estimator sees drawn on the video: the estimated links from their keypoints, and
        the angles and trust factor as text. With ``ahead_when_drawn``, the next frame
        is first read (waiting for a live source) and handed to the estimator."""
        if self._ahead_when_drawn and self._prefetch is not None and self._upcoming:
            asked = time.perf_counter()
            ahead = self._upcoming(wait=True)
            if ahead is not None and ahead is not self._ahead:
                self._prefetch(ahead)
                self._ahead, self._ahead_asked = ahead, asked
        picture = cast("np.ndarray | None", self.env.render())  # render_mode="rgb_array"
        if picture is None or self.last_estimate is None:
            return picture
        # A preview drawn smaller than the frames (render_height) scales the keypoints.
        caption = getattr(self.estimator, "caption", None)  # an estimator may say it
        picture = draw_estimate(picture, self.last_estimate, self._parents,
                                scale=picture.shape[0] / self._frame_height,
                                caption=caption() if callable(caption) else None)
        # And draw more (a 3-D reading), on draw_estimate's copy, which is this wrapper's.
        draw = getattr(self.estimator, "draw", None)
        return draw(picture) if callable(draw) else picture

    def observation(self, observation: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        frame = observation["frame"]
        self.frame_asked = self._ahead_asked if frame is self._ahead else None
        if (self._prefetch is not None and self._upcoming is not None
                and not self._ahead_when_drawn):
            if frame is not self._ahead:  # the first frame, or one not known ahead
                self._prefetch(frame)
            self._ahead = self._upcoming()
            if self._ahead is not None:
                self._prefetch(self._ahead)
        self.last_estimate = self.estimator.update(frame)
        vector = np.clip(self.last_estimate.as_vector(), self._low, self._high)
        out = {k: v for k, v in observation.items() if self.keep_frame or k != "frame"}
        out["estimate"] = vector
        return out


class RegistryObservation(EstimatorObservation):
    """`EstimatorObservation` with the registered estimator ``name``
    (`estimators.registry`), built from the env's `EstimatorContext` with ``params``.
    A spatial estimator (on ``ImitateVideo3D-v0``) is read through the env's retargeter
    (`wrappers.spatial.RetargetedEstimator`): the estimate holds the robot's joint
    targets. ``estimate_ahead``, ``ahead_when_drawn``: as in `EstimatorObservation`. Raises
    `UnsupportedClipError` for a clip it cannot follow. The name and
    parameters, not the estimator, are what ``gym.make(env.spec)`` and a vector env's
    sub-processes rebuild it from."""

    def __init__(self, env: gym.Env, name: str, keep_frame: bool = True,
                 *, estimate_ahead: bool = False, ahead_when_drawn: bool = False,
                 **params: Any) -> None:
        gym.utils.RecordConstructorArgs.__init__(self, name=name, keep_frame=keep_frame,
                                                 estimate_ahead=estimate_ahead,
                                                 ahead_when_drawn=ahead_when_drawn, **params)
        context = estimator_context(env)
        estimator: Estimator
        if get_estimator(name).spatial:
            from imimic_gym.wrappers.spatial import RetargetedEstimator

            low, high = np.array(context.joint_ranges).T
            estimator = RetargetedEstimator(
                build_spatial_estimator(name, context, **params),
                env.get_wrapper_attr("retarget"), context.fps, start=(low + high) / 2)
        else:
            estimator = build_estimator(name, context, **params)
        super().__init__(env, estimator, keep_frame=keep_frame, estimate_ahead=estimate_ahead,
                         ahead_when_drawn=ahead_when_drawn)


class DONObservation(EstimatorObservation):
    """`EstimatorObservation` with DON (registry name ``"don"``), set up from the env: its
    frame rate, the clip's reference direction, the joint's range, the modality's
    smoothing and the robot's model for torques. ``don_params`` go to `DON` and override
    these. An arm with several links gets DON for a tree of links (`LinkedDON`)."""

    def __init__(self, env: gym.Env, keep_frame: bool = True, **don_params: Any) -> None:
        gym.utils.RecordConstructorArgs.__init__(self, keep_frame=keep_frame, **don_params)
        estimator = build_estimator("don", estimator_context(env), **don_params)
        super().__init__(env, estimator, keep_frame=keep_frame)


class CNNObservation(EstimatorObservation):
    """`EstimatorObservation` with the CNN + refiner (registry name ``"cnn"``,
    `estimators/cnn/estimator.py`), set up from the env: its frame rate, the clip's reference
    direction, the number of links, and the robot's model for torques. Keypoints become
    joint angles, and the shared path estimator gives angular velocity, acceleration and
    torque.

    Args:
        env: an ImitateVideo env whose demonstrator is a person's arm with 1 or 2 links.
        checkpoint: a checkpoint path; None loads the shipped ``cnn_arm<n>.pt``.
        keep_frame: see `EstimatorObservation`.
        refine: False skips the refiner. Only meaningful for a network whose CNN was trained
            alone: in the shipped ones CNN and refiner were trained together, and the CNN's
            output is the refiner's input, not pixel coordinates.
    """

    def __init__(self, env: gym.Env, checkpoint: str | None = None, keep_frame: bool = True,
                 refine: bool = True) -> None:
        gym.utils.RecordConstructorArgs.__init__(self, checkpoint=checkpoint,
                                                 keep_frame=keep_frame, refine=refine)
        estimator = build_estimator("cnn", estimator_context(env), checkpoint=checkpoint,
                                    refine=refine)
        super().__init__(env, estimator, keep_frame=keep_frame)


class TruthObservation(EstimatorObservation):
    """`EstimatorObservation` with a perfect, zero-latency estimator: the clip's truth
    (registry name ``"oracle"``).

    The evaluation suite's ``oracle`` estimator, so any controller can be scored on what
    it would do with perfect vision. Truth in an observation: never train a policy on it.
    """

    def __init__(self, env: gym.Env, keep_frame: bool = True) -> None:
        gym.utils.RecordConstructorArgs.__init__(self, keep_frame=keep_frame)
        super().__init__(env, build_estimator("oracle", estimator_context(env)),
                         keep_frame=keep_frame)
