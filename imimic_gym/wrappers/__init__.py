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

__all__ = [
    "CNNObservation", "DONObservation", "EstimatorObservation", "RegistryObservation",
    "TruthObservation", "draw_estimate", "estimate_fields", "estimator_context",
]
