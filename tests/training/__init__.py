"""The training scripts' tests, which run each script as a user runs it."""

import subprocess
import sys
from pathlib import Path


def refused(script: Path, flags: list[str], cwd: Path) -> str:
    """Run ``script`` with ``flags`` in ``cwd`` as a user's mistake: exit 2, no traceback
    and no ``cwd/runs`` made. Returns the message, stderr's last line."""
    done = subprocess.run([sys.executable, str(script), *flags], cwd=cwd, capture_output=True,
                          text=True, timeout=120)
    assert done.returncode == 2 and "Traceback" not in done.stderr, done.stderr[-3000:]
    assert not (cwd / "runs").exists()
    return done.stderr.strip().splitlines()[-1]


def option_helps(script: Path) -> dict[str, str]:
    """``script --help``, each option's help text by its first flag (lines joined)."""
    out = subprocess.run([sys.executable, str(script), "--help"], capture_output=True,
                         text=True, timeout=120, check=True).stdout
    helps: dict[str, str] = {}
    for line in out.split("\noptions:\n", 1)[1].splitlines():
        if line.startswith("  -"):
            flag = line.split()[0].rstrip(",")
            helps[flag] = line
        else:
            helps[flag] += " " + line.strip()
    del helps["-h"]
    return helps
