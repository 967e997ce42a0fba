from imimic_gym.wrappers.estimator import DONObservation, EstimatorObservation, estimate_fields

__all__ = ["DONObservation", "EstimatorObservation", "estimate_fields"]
