"""Vision estimators: frames in, joint angles (or the arm in 3-D) and their derivatives out.

One registry (`registry`) and one output type (`types.Estimate`) serve every family:
- `don/`: the paper's DON, layer by layer, for one link and for a tree of links;
- `pose/`: the pretrained pose model and its estimators, in the image and in 3-D;
- `cnn/`: the paper's keypoint CNN;
- `baselines`: OpenCV's trackers behind DON's interface.
Shared by all: frame preparation (`frames`), joint limits (`joint_range`) and the path
estimator with joint torques (`motion`).
"""

from imimic_gym.estimators.don.one_link import DON, FrameShapeError
from imimic_gym.estimators.types import Estimate, Estimator

__all__ = ["DON", "Estimate", "Estimator", "FrameShapeError"]
