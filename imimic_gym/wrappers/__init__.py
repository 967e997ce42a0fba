from imimic_gym.wrappers.estimator import (
    CNNObservation,
    DONObservation,
    EstimatorObservation,
    draw_estimate,
    estimate_fields,
)

__all__ = [
    "CNNObservation", "DONObservation", "EstimatorObservation", "draw_estimate",
    "estimate_fields",
]
