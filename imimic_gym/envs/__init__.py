from imimic_gym.envs.imitate_video import ImitateVideoEnv

__all__ = ["ImitateVideoEnv"]
