"""Vision estimators: frames in, joint angles and their derivatives out."""

from imimic_gym.estimators.don import DON, FrameShapeError
from imimic_gym.estimators.types import Estimate, Estimator

__all__ = ["DON", "Estimate", "Estimator", "FrameShapeError"]
