from imimic_gym.controllers.scripted import (
    OracleController,
    PDController,
    TargetSource,
    TruthTarget,
)

__all__ = ["OracleController", "PDController", "TargetSource", "TruthTarget"]
