from imimic_gym.wrappers.estimator import (
    CNNObservation,
    DONObservation,
    EstimatorObservation,
    RegistryObservation,
    TruthObservation,
    draw_estimate,
    estimate_fields,
    estimator_context,
)
from imimic_gym.wrappers.render_ahead import RenderAhead

__all__ = [
    "CNNObservation", "DONObservation", "EstimatorObservation", "RegistryObservation",
    "RenderAhead", "TruthObservation", "draw_estimate", "estimate_fields", "estimator_context",
]
