from imimic_gym.wrappers.estimator import (
    DONObservation,
    EstimatorObservation,
    TruthObservation,
    estimate_fields,
)

__all__ = ["DONObservation", "EstimatorObservation", "TruthObservation", "estimate_fields"]
