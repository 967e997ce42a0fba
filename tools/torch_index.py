"""Print pip's option for PyTorch's CPU-only index when that index answers within a few
seconds, else nothing (the Makefile adds it to `pip install torch==2.13.0`).

On Linux x86_64, PyPI's torch 2.13.0 is a CUDA build of several GB; the CPU index's
2.13.0+cpu ranks above it (a local version), so pip takes the CPU build. Where the index
cannot be reached (a machine that sees only PyPI) pip takes what its own indexes hold.
"""

import sys
import urllib.request

CPU_INDEX = "https://download.pytorch.org/whl/cpu"


def main() -> None:
    try:
        with urllib.request.urlopen(f"{CPU_INDEX}/torch/", timeout=4) as answer:
            reachable = answer.status == 200
    except OSError:
        reachable = False
    if reachable:
        sys.stdout.write(f"--extra-index-url {CPU_INDEX}\n")


if __name__ == "__main__":
    main()
