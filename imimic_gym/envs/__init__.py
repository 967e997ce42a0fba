from imimic_gym.envs.imitate_video import ImitateVideoEnv
from imimic_gym.envs.imitate_video_3d import ImitateVideo3DEnv

__all__ = ["ImitateVideo3DEnv", "ImitateVideoEnv"]
