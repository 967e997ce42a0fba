"""What DON's compiled loops (`imimic_gym/estimators/compiled.py`) cost a fresh install once:
the wall time of a new process importing DON and running it on the bench's frames with an
empty numba cache (everything compiled), and of the next process doing the same (the loops
loaded from the cache), beside a second run in the same process (nothing left to load).
Each process has ``NUMBA_CACHE_DIR`` pointing at a new temporary folder, so the project's
own cache is not touched. Usage:

    .venv/bin/python benchmarks/don_compile_time.py --json benchmarks/results/don_compile_time.json
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

from imimic_gym.bench import machine

# One process: DON over the default scenario's frames (from the clip cache), twice; prints
# the first run's wall time (with whatever compiling or loading it needs) and the second's.
RUN = """
import time
from imimic_gym.clips.cache import load_clip
from imimic_gym.clips.scenarios import get_scenario
clip = load_clip(get_scenario("default", n_frames=90), progress=False)
start = time.perf_counter()
from imimic_gym.estimators.don import DON
DON().run(clip.frames)
first = time.perf_counter() - start
start = time.perf_counter()
DON().run(clip.frames)
print(first, time.perf_counter() - start)
"""


def one_process(cache: str) -> tuple[float, float]:
    """(first run s, second run s) of a new process with numba's cache in ``cache``."""
    out = subprocess.run([sys.executable, "-c", RUN], check=True, capture_output=True,
                         text=True, env={**os.environ, "NUMBA_CACHE_DIR": cache})
    first, second = map(float, out.stdout.split()[-2:])
    return first, second


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--json", type=Path, default=None, help="also write results here")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as cache:
        cold, compiled = one_process(cache)  # compiles every loop, fills the cache
        warm, _ = one_process(cache)  # loads them
    result = {"machine": machine(), "frames": 90, "cold_first_run_s": cold,
              "cached_first_run_s": warm, "compiled_run_s": compiled}
    print(f"first DON run (90 frames, 240x320): empty cache {cold:.2f} s, filled cache "
          f"{warm:.2f} s; once compiled {compiled:.2f} s")
    if args.json:
        args.json.write_text(json.dumps(result, indent=2) + "\n")


if __name__ == "__main__":
    main()
