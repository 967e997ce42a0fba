from imimic_gym.wrappers.estimator import (
    CNNObservation,
    DONObservation,
    EstimatorObservation,
    TruthObservation,
    draw_estimate,
    estimate_fields,
)

__all__ = [
    "CNNObservation", "DONObservation", "EstimatorObservation", "TruthObservation",
    "draw_estimate", "estimate_fields",
]
