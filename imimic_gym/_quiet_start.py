"""A Ctrl-C while the `imimic` command starts, before `cli.main` can catch anything (its
imports take a few tenths of a second), ends it in one line with exit code 130 rather than
with a traceback from inside an import. Imported first by the package, so it imports
only what Python has loaded at start-up."""

import itertools
import os
import signal
import sys
from types import FrameType

__all__ = ["quiet_start", "restore_ctrl_c"]


def _stop_quietly(signum: int, frame: FrameType | None) -> None:
    """Exit at once: only imports have run, and an exception raised here would reach
    the user as a failed import (a compiled module's initialisation wraps it)."""
    sys.stderr.write("imimic: stopped by Ctrl-C\n")
    sys.stderr.flush()
    os._exit(130)


def _is_the_command() -> bool:
    """Whether this process is the `imimic` command: its console script, or ``python -m
    imimic_gym.cli``."""
    if os.path.basename(sys.argv[0]).removesuffix(".exe") == "imimic":
        return True
    argv = list(getattr(sys, "orig_argv", ()))
    return any(flag == "-m" and module in ("imimic_gym.cli", "imimic_gym.cli.__main__")
               for flag, module in itertools.pairwise(argv))


def quiet_start() -> None:
    """In the `imimic` command only (a library user's Ctrl-C stays a KeyboardInterrupt):
    until `restore_ctrl_c`, Ctrl-C prints one line and exits with code 130."""
    if _is_the_command():
        try:
            signal.signal(signal.SIGINT, _stop_quietly)
        except ValueError:  # not the main thread: signals are not ours to set
            pass


def restore_ctrl_c() -> None:
    """Ctrl-C raises KeyboardInterrupt again, if `quiet_start` had changed it."""
    if signal.getsignal(signal.SIGINT) is _stop_quietly:
        signal.signal(signal.SIGINT, signal.default_int_handler)
