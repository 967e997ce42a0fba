"""Headless OpenGL defaults, applied before MuJoCo is imported. A user's own setting wins.

- ``MUJOCO_GL=egl``: render without a display (Mesa's software renderer on CPU machines).
- ``LP_NUM_THREADS=1``: at 240x320, llvmpipe spends more on handing tiles between threads
  than it gains (measured: 2.6 ms vs 4.2 ms a pass with two threads on 2 cores).
"""

import os
import sys

if sys.platform.startswith("linux") and not os.environ.get("DISPLAY"):
    os.environ.setdefault("MUJOCO_GL", "egl")
os.environ.setdefault("LP_NUM_THREADS", "1")
