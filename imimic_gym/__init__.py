"""imimic_gym: a robot arm that learns to copy a human arm it sees on video."""

from imimic_gym._quiet_start import quiet_start

quiet_start()  # the imimic command: a Ctrl-C in the imports below is one line, no traceback

from gymnasium.envs.registration import register  # noqa: E402

from imimic_gym import _gl  # noqa: E402, F401  (headless GL defaults, before MuJoCo loads)
from imimic_gym.clips import (  # noqa: E402
    Clip,
    ClipSpec,
    ClipTruth,
    get_scenario,
    load_clip,
    scenario_names,
)
from imimic_gym.robots.planar import ArmSpec  # noqa: E402

__all__ = [
    "ArmSpec", "Clip", "ClipSpec", "ClipTruth", "get_scenario", "load_clip", "scenario_names",
]
__version__ = "0.1.0"

# One episode is one clip and the env truncates at its end, so no TimeLimit is registered.
register(id="ImitateVideo-v0", entry_point="imimic_gym.envs.imitate_video:ImitateVideoEnv")
register(id="ImitateVideo3D-v0",
         entry_point="imimic_gym.envs.imitate_video_3d:ImitateVideo3DEnv")
