from imimic_gym.controllers.scripted import (
    EstimateTarget,
    OracleController,
    PDController,
    TargetSource,
    TruthTarget,
)

__all__ = ["EstimateTarget", "OracleController", "PDController", "TargetSource", "TruthTarget"]
