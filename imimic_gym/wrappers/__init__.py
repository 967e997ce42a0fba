from imimic_gym.wrappers.estimator import (
    CNNObservation,
    DONObservation,
    EstimatorObservation,
    estimate_fields,
)

__all__ = ["CNNObservation", "DONObservation", "EstimatorObservation", "estimate_fields"]
