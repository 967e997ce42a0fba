"""`RenderAhead`: the robot view of each new state starts drawing as soon as the env has
stepped, so that the work above it (an estimator reading the frame) overlaps the drawing."""

from __future__ import annotations

from typing import Any, SupportsFloat

import gymnasium as gym
import numpy as np

__all__ = ["RenderAhead"]


class RenderAhead(gym.Wrapper):
    """After every ``reset`` and ``step`` of an ImitateVideo env (``render_mode=
    "rgb_array"``), starts drawing its robot view (`ImitateVideoEnv.prepare_render`):
    Mesa's software renderer draws it on its own thread while the wrappers above this one
    work (an `EstimatorObservation` estimating the frame), and ``render()`` then only
    reads it back. The pictures are the same as without it. Put it directly on the env,
    under the estimator's wrapper; it pays off when every state is rendered."""

    def __init__(self, env: gym.Env) -> None:
        super().__init__(env)
        self._prepare = env.get_wrapper_attr("prepare_render")

    def reset(self, **kwargs: Any) -> tuple[Any, dict[str, Any]]:
        result = self.env.reset(**kwargs)
        self._prepare()
        return result

    def step(self, action: np.ndarray
             ) -> tuple[Any, SupportsFloat, bool, bool, dict[str, Any]]:
        result = self.env.step(action)
        self._prepare()
        return result
