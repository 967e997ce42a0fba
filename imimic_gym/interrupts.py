"""Ctrl-C as the commands that keep their partial work see it.

A Ctrl-C that lands inside a compiled numba loop (DON's layers) does not arrive as a bare
`KeyboardInterrupt`: Python raises a `SystemError` ("returned a result with an exception
set") over it, once per compiled call it interrupts; one that stops a compiled module's
initialisation arrives as an ImportError over it. One that lands in a ctypes call's
argument conversion (PyOpenGL's, while the renderer opens its GL context) arrives as a
`ctypes.ArgumentError` whose message names the KeyboardInterrupt. Catch `CTRL_C` and ask
`is_ctrl_c`.

Before the `imimic` command can catch anything, its imports take a few tenths of a second:
`imimic_gym._quiet_start` covers them.
"""

from __future__ import annotations

import re
import signal
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from ctypes import ArgumentError

__all__ = ["CTRL_C", "ctrl_c_held", "is_ctrl_c", "unstoppable"]

# What to catch; then ask is_ctrl_c.
CTRL_C = (KeyboardInterrupt, SystemError, ArgumentError, ImportError)

# ctypes' message for an exception raised while it converted argument N.
_CTYPES_INTERRUPTED = re.compile(r"argument \d+: KeyboardInterrupt\b")


def is_ctrl_c(error: BaseException | None) -> bool:
    """Whether ``error`` is Ctrl-C: a KeyboardInterrupt, SystemErrors or ImportErrors (a
    compiled module whose initialisation it stopped) raised over one, or ctypes'
    ArgumentError for a KeyboardInterrupt in an argument's conversion."""
    while isinstance(error, (SystemError, ImportError)):
        error = error.__cause__
    if isinstance(error, ArgumentError):
        return bool(_CTYPES_INTERRUPTED.match(str(error)))
    return isinstance(error, KeyboardInterrupt)


@contextmanager
def unstoppable() -> Iterator[None]:
    """Ctrl-C ignored inside (in the main thread; elsewhere signals go to the main thread
    anyway): for what must finish once started, such as releasing a robot's torque, which a
    second Ctrl-C must not cut short."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


@contextmanager
def ctrl_c_held() -> Iterator[None]:
    """Ctrl-C held back inside (in the main thread) and delivered to the handler there was
    before as the block ends (Python's own raises KeyboardInterrupt): for steps that must
    happen together or not at all, such as logging a frame and handing it to the video
    writer. A generator may hold it across a ``yield``: the consumer's hand-over is then
    inside too. Where Ctrl-C is ignored (a background job) nothing changes."""
    previous = signal.getsignal(signal.SIGINT)
    if (threading.current_thread() is not threading.main_thread()
            or previous in (signal.SIG_IGN, None)):
        yield
        return
    pressed: list[int] = []
    signal.signal(signal.SIGINT, lambda number, _frame: pressed.append(number))
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)
    if pressed:
        signal.raise_signal(signal.SIGINT)  # its handler runs before this returns
