from imimic_gym.wrappers.estimator import (
    DONObservation,
    EstimatorObservation,
    draw_estimate,
    estimate_fields,
)

__all__ = ["DONObservation", "EstimatorObservation", "draw_estimate", "estimate_fields"]
