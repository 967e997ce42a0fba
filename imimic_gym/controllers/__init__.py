from imimic_gym.controllers.learned import LearnedController
from imimic_gym.controllers.scripted import (
    SCRIPTED_CONTROLLERS,
    EstimateTarget,
    OracleController,
    PDController,
    PositionController,
    TargetSource,
    TorqueController,
    TruthTarget,
    VelocityController,
)

__all__ = [
    "SCRIPTED_CONTROLLERS", "EstimateTarget", "LearnedController", "OracleController",
    "PDController",
    "PositionController", "TargetSource", "TorqueController", "TruthTarget",
    "VelocityController",
]
