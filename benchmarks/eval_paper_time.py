"""Wall time of `imimic eval --paper` as a fresh clone sees it: an empty clip cache, so
every clip it needs is rendered first. Writes the seconds, the command and the machine.

Usage: .venv/bin/python benchmarks/eval_paper_time.py --json benchmarks/results/paper_time.json
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from imimic_gym.bench import machine


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--json", default=None, help="write the result to this file")
    args = parser.parse_args()
    imimic = Path(sys.executable).with_name("imimic")
    with tempfile.TemporaryDirectory() as cache, tempfile.TemporaryDirectory() as out:
        command = [str(imimic), "eval", "--paper", "--out", out]
        env = {**os.environ, "IMIMIC_CACHE_DIR": cache, "MUJOCO_GL": "egl"}
        start = time.perf_counter()
        subprocess.run(command, check=True, env=env, stdout=subprocess.DEVNULL)
        seconds = time.perf_counter() - start
    result = {"machine": machine(), "command": "imimic eval --paper (empty clip cache)",
              "seconds": round(seconds, 1), "limit_seconds": 600}
    print(f"imimic eval --paper from an empty cache: {seconds:.0f} s (limit 600 s)")
    if args.json:
        Path(args.json).write_text(json.dumps(result, indent=2) + "\n")


if __name__ == "__main__":
    main()
