"""Ctrl-C as the commands that keep their partial work see it.

A Ctrl-C that lands inside a compiled numba loop (DON's layers) does not arrive as a bare
`KeyboardInterrupt`: Python raises a `SystemError` ("returned a result with an exception
set") over it, once per compiled call it interrupts. One that lands in a ctypes call's
argument conversion (PyOpenGL's, while the renderer opens its GL context) arrives as a
`ctypes.ArgumentError` whose message names the KeyboardInterrupt. Catch `CTRL_C` and ask
`is_ctrl_c`.

Before the `imimic` command can catch anything, its imports take a few tenths of a second;
`quiet_start` makes a Ctrl-C then end it in one line (exit code 130) rather than with a
traceback from inside an import, and `cli.main` hands Ctrl-C back to the commands with
`restore_ctrl_c` once it can catch it.
"""

from __future__ import annotations

import os
import re
import signal
import sys
import threading
from ctypes import ArgumentError
from itertools import pairwise
from types import FrameType

__all__ = ["CTRL_C", "is_ctrl_c", "quiet_start", "restore_ctrl_c"]

CTRL_C = (KeyboardInterrupt, SystemError, ArgumentError)  # what to catch; then ask is_ctrl_c

# ctypes' message for an exception raised while it converted argument N.
_CTYPES_INTERRUPTED = re.compile(r"argument \d+: KeyboardInterrupt\b")


def is_ctrl_c(error: BaseException | None) -> bool:
    """Whether ``error`` is Ctrl-C: a KeyboardInterrupt, SystemErrors raised over one, or
    ctypes' ArgumentError for a KeyboardInterrupt in an argument's conversion."""
    while isinstance(error, SystemError):
        error = error.__cause__
    if isinstance(error, ArgumentError):
        return bool(_CTYPES_INTERRUPTED.match(str(error)))
    return isinstance(error, KeyboardInterrupt)


def _stop_quietly(signum: int, frame: FrameType | None) -> None:
    print("imimic: stopped by Ctrl-C", file=sys.stderr)
    raise SystemExit(130)


def _is_the_command() -> bool:
    """Whether this process is the `imimic` command: its console script, or ``python -m
    imimic_gym.cli``."""
    if os.path.basename(sys.argv[0]).removesuffix(".exe") == "imimic":
        return True
    argv = list(getattr(sys, "orig_argv", ()))
    return any(flag == "-m" and module in ("imimic_gym.cli", "imimic_gym.cli.__main__")
               for flag, module in pairwise(argv))


def quiet_start() -> None:
    """In the `imimic` command only (a library user's Ctrl-C stays a KeyboardInterrupt):
    until `restore_ctrl_c`, Ctrl-C prints one line and exits with code 130."""
    if threading.current_thread() is threading.main_thread() and _is_the_command():
        signal.signal(signal.SIGINT, _stop_quietly)


def restore_ctrl_c() -> None:
    """Ctrl-C raises KeyboardInterrupt again, if `quiet_start` had changed it."""
    if signal.getsignal(signal.SIGINT) is _stop_quietly:
        signal.signal(signal.SIGINT, signal.default_int_handler)
