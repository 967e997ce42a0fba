from imimic_gym.wrappers.estimator import (
    CNNObservation,
    DONObservation,
    EstimatorObservation,
    TruthObservation,
    draw_estimate,
    estimate_fields,
    estimator_context,
)

__all__ = [
    "CNNObservation", "DONObservation", "EstimatorObservation", "TruthObservation",
    "draw_estimate", "estimate_fields", "estimator_context",
]
